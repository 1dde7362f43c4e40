// meniscus — a built-in software rasterizer for preview pictures of a mesh, and a PNG writer.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// How render_mesh draws a mesh. Colours are sRGB components in [0, 1] (as in a colour picker);
/// lighting is computed in linear light and the output is sRGB-encoded.
///
/// The view is a fixed three-quarter view: a perspective camera looks at the centre of the mesh's
/// bounding box from azimuth `yaw_degrees` and elevation `pitch_degrees` (measured around and
/// from the plane perpendicular to `up`) and is zoomed so that the projected bounding box spans
/// `frame_fill` of the image's limiting dimension. The surface is lit by a warm key light from
/// the viewer's upper left, a weaker cool fill light from the right and a sky/ground ambient,
/// with Blinn-Phong highlights and a Fresnel reflection of the sky at grazing angles. Back faces
/// (seen through holes of open meshes) are drawn dimmer and without highlights.
struct RenderOptions {
  /// Output size in pixels, each in [1, 8192]. Rendered at 2×2 the size and box-filtered down.
  int width = 960, height = 720;
  /// Camera azimuth around `up` (0: looking from the first horizontal axis, +x for z-up) and
  /// elevation above the horizontal plane, in degrees; pitch in [-89, 89].
  float yaw_degrees = 35, pitch_degrees = 30;
  /// World "up" direction (need not be unit length, must be non-zero). Fluid scenes here are
  /// z-up; use {0, 1, 0} for y-up data.
  Vec3f up{0, 0, 1};
  /// Strength of perspective, in [1, 120] degrees: the camera stands where the bounding sphere
  /// of the bounding box spans this angle. Small values approach an orthographic view.
  float field_of_view_degrees = 30;
  /// Fraction of the limiting image dimension that the projected bounding box spans, in (0, 1].
  float frame_fill = 0.85f;
  /// Surface colour when no colour attribute is used (water blue).
  Vec3f base_color{0.30f, 0.55f, 0.85f};
  /// If non-empty and the mesh has a per-vertex attribute of this name with 3 components (RGB
  /// in [0, 1], clamped) or 1 component (mapped through the viridis colormap normalized to the
  /// attribute's finite min..max), the surface is coloured by it; otherwise base_color is used.
  std::string color_attribute;
  /// Optional overlay, not owned: particles drawn as small shaded dots, depth-tested against the
  /// surface (so particles inside a closed surface are hidden). Non-finite positions are skipped.
  const ParticleSet* particles = nullptr;
  Vec3f particle_color{0.95f, 0.50f, 0.20f};
  /// Dot radius in output pixels, in [0.25, 64].
  float particle_radius_pixels = 1.5f;
  /// Vertical gradient from `background_top` (top row) to `background_bottom` (bottom row); when
  /// false the whole background is `background_top`.
  bool background_gradient = true;
  Vec3f background_top{0.93f, 0.95f, 0.97f};
  Vec3f background_bottom{0.71f, 0.75f, 0.80f};

  /// Throws InvalidParameter naming the first member out of range or not finite.
  void validate() const;
};

/// An 8-bit RGB image: `rgb` holds width × height × 3 bytes, row-major, top row first.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

/// The pinhole camera render_mesh uses (exposed so callers can place annotations on the picture
/// and tests can predict where things land). A world point p has view coordinates
/// (a, b, c) = (dot(p − eye, right), dot(p − eye, up), dot(p − eye, forward)) and lands at
/// pixel coordinates (cx + focal·a/c, cy − focal·b/c), where pixel (i, j) covers
/// [i, i+1) × [j, j+1) and row 0 is the top of the image. `forward`, `right`, `up` are
/// orthonormal; `target` (the bounding-box centre) lies on the optical axis.
struct Camera {
  Vec3f eye, target;
  Vec3f forward, right, up;
  float focal = 1;       ///< pixels per unit of a/c
  float cx = 0, cy = 0;  ///< principal point, pixels
  int width = 0, height = 0;
};

/// The camera render_mesh(mesh, options) uses: framed on the bounding box of the mesh's finite
/// vertices; if the mesh has none, on options.particles; if that is empty too, on the origin.
/// Throws InvalidParameter for invalid options.
Camera frame_camera(const TriangleMesh& mesh, const RenderOptions& options = {});

/// Pixel x, y (as described at Camera) and view depth c of a world point. Only meaningful when
/// the returned depth (z) is positive, i.e. the point is in front of the camera.
Vec3f project(const Camera& camera, Vec3f point);

/// Renders the mesh to an options.width × options.height image. Triangles touching a vertex
/// that is not finite are skipped; an empty mesh gives the background only. Smooth shading when
/// mesh.normals has one normal per vertex, flat shading from face normals when it is empty.
/// Deterministic: the same input gives the same bytes whatever the number of threads.
/// Memory: about 32 bytes per output pixel (the 2×2 supersampled depth and primitive buffers)
/// plus about 12 bytes per triangle and 8 per vertex.
/// Runs in parallel on the calling thread's oneTBB arena; safe to call concurrently.
/// Throws InvalidParameter for invalid options, a triangle index out of range, a normals array
/// that is neither empty nor one per vertex, or a colour attribute whose length does not match
/// the vertex count.
Image render_mesh(const TriangleMesh& mesh, const RenderOptions& options = {});

/// Writes the image as an 8-bit RGB PNG. The file is written to a temporary name in the same
/// directory and renamed when complete, so a failure never leaves a partial or temporary file.
/// Throws InvalidParameter if rgb.size() does not match width × height × 3 (or a size is not
/// positive), IoError naming the file when it cannot be written.
void write_png(const std::string& path, const Image& image);

}  // namespace meniscus
