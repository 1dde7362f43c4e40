// meniscus — a built-in software rasterizer for preview pictures of a mesh, and a PNG writer.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// An axis-aligned box.
struct Bounds {
  Vec3f lo, hi;
};

/// How render_mesh draws a mesh. Colours are sRGB components in [0, 1] (as in a colour picker);
/// lighting is computed in linear light and the output is sRGB-encoded.
///
/// The view is a fixed three-quarter view: a perspective camera looks at the centre of the mesh's
/// bounding box (or of `frame_bounds`) from azimuth `yaw_degrees` and elevation `pitch_degrees` (measured around and
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
  /// If non-empty, the surface is coloured by the mesh's per-vertex attribute of this name (see
  /// color_mapping): a scalar, or the magnitude of a 3-component vector, through the viridis
  /// colormap over `color_range`; a 3-component attribute named like a colour as RGB in [0, 1]
  /// (clamped). Empty: base_color. render_mesh throws InvalidParameter listing the attributes
  /// the mesh has when there is none of this name or it has neither 1 nor 3 components.
  std::string color_attribute;
  /// The values mapped onto the ends of the colormap (lo: dark purple, hi: yellow; values
  /// outside are clamped, non-finite ones drawn as lo). Unset: the attribute's own finite
  /// min..max (color_value_range). lo < hi, both finite.
  std::optional<std::array<float, 2>> color_range;
  /// Frame the camera on this box instead of the bounds of the mesh, so that several pictures
  /// (the frames of a sequence) share one position and scale. lo ≤ hi componentwise, finite.
  std::optional<Bounds> frame_bounds;
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

/// The up axis of a scene, and what decided it.
struct UpAxis {
  int axis = 2;        ///< 0: x, 1: y, 2: z
  std::string reason;  ///< in words, for a summary: "the file is a Houdini geometry file, y-up by convention"
  Vec3f direction() const;
  char name() const { return char('x' + axis); }
};

/// Which axis is up in a scene, from what its file says and what its points show:
/// - `format` (a ReadReport's) names a Houdini geometry file (bgeo, bgeo.sc, partio's bgeo):
///   y, Houdini's convention;
/// - otherwise gravity as the points show it: per axis, how clearly the mean `velocity` (a
///   3-component attribute, or nullptr) points down it (its component against the mean speed)
///   plus how low the centre of mass sits in the bounding box (below the middle); the axis with
///   the highest score when it is clear (at least 0.1, and 0.04 above every other axis);
/// - otherwise z, the default of most simulators outside Houdini and SPlisHSPlasH.
/// Non-finite points and velocities are skipped. O(points).
UpAxis guess_up_axis(const std::vector<Vec3f>& points, const Attribute* velocity, std::string_view format);

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

/// How an attribute colours the surface: `rgb` for 3 components when the name says colour
/// ("color", "colour", "Cd", "rgb" or containing "color"/"colour", any case), `magnitude` for
/// other 3-component attributes (velocity, normal …), `scalar` for 1 component. Throws
/// InvalidParameter naming the attribute when it has another number of components.
enum class ColorMapping { rgb, scalar, magnitude };
ColorMapping color_mapping(const Attribute& attribute);

/// The finite min and max of the values the colormap would show for `attribute` (the scalar or
/// the vector magnitude), nullopt when it has no finite value or is mapped as RGB.
std::optional<std::array<float, 2>> color_value_range(const Attribute& attribute);

/// `views` pictures of the mesh side by side, at azimuths options.yaw_degrees + 360°·k / views
/// (k = 0 … views − 1), each options.width × options.height and framed on its own: a turntable
/// strip views·width wide. Throws InvalidParameter when views is not in [1, 64].
Image render_turntable(const TriangleMesh& mesh, const RenderOptions& options, int views);

/// The images as a grid, row-major, `columns` per row (the last row filled from the left, the
/// rest of it black). Every image must have the same size. Throws InvalidParameter for no
/// images, columns < 1, mismatched sizes, or a result over 2^30 pixels.
Image join_images(const std::vector<Image>& images, int columns);

/// Writes the image as an 8-bit RGB PNG. The file is written to a temporary name in the same
/// directory and renamed when complete, so a failure never leaves a partial or temporary file.
/// Throws InvalidParameter if rgb.size() does not match width × height × 3 (or a size is not
/// positive), IoError naming the file when it cannot be written.
void write_png(const std::string& path, const Image& image);

}  // namespace meniscus
