"""meniscus.temporal_smoothing: a frame's positions smoothed in time with the frames either side,
matched by id whatever the order, as `meniscus surface` does for a sequence."""
import numpy as np
import pytest

import meniscus


def frame(base, offset, rng):
    """The particles at base + offset (per particle), in a random order, with their ids."""
    order = rng.permutation(len(base))
    return (base + offset)[order].astype(np.float32), order.astype(np.int64)


def by_id(positions, ids):
    out = np.empty_like(positions)
    out[ids] = positions
    return out


def test_steady_motion_is_kept_and_noise_is_filtered():
    rng = np.random.default_rng(3)
    base = rng.uniform(0, 1, (2000, 3))
    v = np.array([0.01, -0.02, 0.005])
    frames = [frame(base, v * t, rng) for t in (4, 5, 6)]
    smoothed, report = meniscus.temporal_smoothing(*frames, limit=0.05)
    assert report["applied"] and report["matched"] == 2000 and report["clamped"] == 0
    assert smoothed.dtype == np.float32 and smoothed.shape == (2000, 3)
    assert np.abs(smoothed - frames[1][0]).max() < 1e-6  # in the current frame's order

    noise = [rng.normal(0, 0.004, base.shape) for _ in range(3)]
    frames = [frame(base, noise[t], rng) for t in range(3)]
    smoothed, report = meniscus.temporal_smoothing(*frames, weight=0.25, limit=1.0)
    got = by_id(smoothed, frames[1][1])
    expected = base + 0.5 * noise[1] + 0.25 * (noise[0] + noise[2])
    assert np.abs(got - expected).max() < 2e-6
    # Independent noise keeps (1/2)² + 2 (1/4)² = 3/8 of its variance.
    assert np.var(got - base) / np.var(noise[1]) == pytest.approx(0.375, abs=0.05)


def test_shifts_are_cut_to_the_limit_and_reasons_are_given():
    rng = np.random.default_rng(4)
    base = rng.uniform(0, 1, (500, 3))
    jump = np.zeros_like(base)
    jump[7] = [3.0, 0, 0]
    frames = [frame(base, 0, rng), frame(base, 0, rng), frame(base, jump, rng)]
    smoothed, report = meniscus.temporal_smoothing(*frames, limit=0.01)
    assert report["clamped"] == 1 and report["max_shift"] == pytest.approx(0.01, abs=1e-7)
    assert by_id(smoothed, frames[1][1])[7] == pytest.approx(base[7] + [0.01, 0, 0], abs=1e-6)

    positions, ids = frames[1]
    twice = ids.copy()
    twice[1] = twice[0]
    smoothed, report = meniscus.temporal_smoothing(frames[0], (positions, twice), frames[2], limit=0.01)
    assert not report["applied"] and "two particles with id" in report["skipped"]
    assert np.array_equal(smoothed, positions)


def test_particles_objects_and_bad_input():
    rng = np.random.default_rng(5)
    base = rng.uniform(0, 1, (300, 3))
    frames = [frame(base, rng.normal(0, 0.003, base.shape), rng) for _ in range(3)]
    particles = [meniscus.Particles(p, {"id": i}) for p, i in frames]
    a, _ = meniscus.temporal_smoothing(*particles, limit=0.02)
    b, _ = meniscus.temporal_smoothing(*frames, limit=0.02)
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="no 'id' attribute"):
        meniscus.temporal_smoothing(meniscus.Particles(frames[0][0]), particles[1], particles[2])
    with pytest.raises(ValueError, match=r"ids must have shape \(300,\), got \(10,\)"):
        meniscus.temporal_smoothing(frames[0], (frames[1][0], frames[1][1][:10]), frames[2], limit=0.02)
    with pytest.raises(ValueError, match="temporal_smoothing"):
        meniscus.temporal_smoothing(*frames, weight=0.7, limit=0.02)
