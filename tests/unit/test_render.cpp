// meniscus tests — the preview rasterizer (render_mesh, frame_camera) and the PNG writer.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <tbb/task_arena.h>

#include "meniscus/errors.hpp"
#include "meniscus/render.hpp"
#include "support/png_decode.hpp"
#include "support/test_support.hpp"


namespace meniscus {
namespace {

using test::icosphere;

struct Rgb {
  int r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

Rgb pixel(const Image& image, int x, int y) {
  const std::size_t i = (std::size_t(y) * std::size_t(image.width) + std::size_t(x)) * 3;
  return {image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]};
}

Rgb to_bytes(Vec3f srgb) {
  return {int(std::lround(srgb.x * 255)), int(std::lround(srgb.y * 255)), int(std::lround(srgb.z * 255))};
}

double luminance(Rgb c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

/// Mean luminance over a (2h+1)² square of pixels.
double mean_luminance(const Image& image, int cx, int cy, int h) {
  double sum = 0;
  int n = 0;
  for (int y = cy - h; y <= cy + h; ++y)
    for (int x = cx - h; x <= cx + h; ++x, ++n) sum += luminance(pixel(image, x, y));
  return sum / n;
}

/// Options with a plain background, so "not background" means "covered".
RenderOptions plain_options(int width = 320, int height = 240) {
  RenderOptions options;
  options.width = width;
  options.height = height;
  options.background_gradient = false;
  return options;
}

/// Where a sphere centred on the framing target lands: a disc around the principal point whose
/// radius follows from the angle the sphere subtends at the eye.
struct Disc {
  double x = 0, y = 0, radius = 0;
};

Disc projected_sphere(const Camera& camera, float sphere_radius) {
  const double distance = length(camera.eye - camera.target);
  return {camera.cx, camera.cy,
          camera.focal * sphere_radius / std::sqrt(distance * distance - sphere_radius * sphere_radius)};
}

TEST(RenderTest, SphereImageHasRequestedSizeAndBackgroundCorners) {
  const RenderOptions options = plain_options(320, 240);
  const Image image = render_mesh(icosphere(3), options);
  EXPECT_EQ(image.width, 320);
  EXPECT_EQ(image.height, 240);
  ASSERT_EQ(image.rgb.size(), std::size_t(320 * 240 * 3));
  const Rgb background = to_bytes(options.background_top);
  EXPECT_EQ(pixel(image, 0, 0), background);
  EXPECT_EQ(pixel(image, 319, 0), background);
  EXPECT_EQ(pixel(image, 0, 239), background);
  EXPECT_EQ(pixel(image, 319, 239), background);
}

TEST(RenderTest, GradientBackgroundRunsFromTopToBottomColour) {
  const RenderOptions options;  // gradient on by default
  const Image image = render_mesh(icosphere(3), options);
  const Rgb top = to_bytes(options.background_top), bottom = to_bytes(options.background_bottom);
  for (const Rgb corner : {pixel(image, 0, 0), pixel(image, image.width - 1, 0)}) {
    EXPECT_NEAR(corner.r, top.r, 2);
    EXPECT_NEAR(corner.g, top.g, 2);
    EXPECT_NEAR(corner.b, top.b, 2);
  }
  for (const Rgb corner : {pixel(image, 0, image.height - 1), pixel(image, image.width - 1, image.height - 1)}) {
    EXPECT_NEAR(corner.r, bottom.r, 2);
    EXPECT_NEAR(corner.g, bottom.g, 2);
    EXPECT_NEAR(corner.b, bottom.b, 2);
  }
}

TEST(RenderTest, SphereCoverageMatchesProjectedDisc) {
  const float radius = 2.5f;
  const TriangleMesh mesh = icosphere(4, radius, {10, -3, 7});
  const RenderOptions options = plain_options(400, 300);
  const Image image = render_mesh(mesh, options);
  const Camera camera = frame_camera(mesh, options);
  const Disc disc = projected_sphere(camera, radius);
  const Rgb background = to_bytes(options.background_top);

  // The sphere centre is the framing target, so it lands near the middle of the image.
  EXPECT_NEAR(disc.x, 200, 20);
  EXPECT_NEAR(disc.y, 150, 20);
  EXPECT_NE(pixel(image, 200, 150), background);
  EXPECT_NE(pixel(image, int(disc.x), int(disc.y)), background);

  std::size_t covered = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) covered += pixel(image, x, y) != background;
  const double expected = std::numbers::pi * disc.radius * disc.radius;
  EXPECT_GT(disc.radius, 40);  // framed to fill a good part of the image
  EXPECT_NEAR(double(covered) / expected, 1.0, 0.15) << covered << " pixels covered, disc of " << expected;
}

TEST(RenderTest, NoCracksBetweenTrianglesSmoothOrFlat) {
  TriangleMesh mesh = icosphere(5);  // 20480 small triangles: many shared edges per pixel row
  for (const bool smooth : {true, false}) {
    if (!smooth) mesh.normals.clear();
    const RenderOptions options = plain_options(480, 360);
    const Image image = render_mesh(mesh, options);
    const Disc disc = projected_sphere(frame_camera(mesh, options), 1.0f);
    const Rgb background = to_bytes(options.background_top);
    int holes = 0, inside = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        if (std::hypot(x + 0.5 - disc.x, y + 0.5 - disc.y) < 0.95 * disc.radius) {
          ++inside;
          holes += pixel(image, x, y) == background;
        }
    EXPECT_GT(inside, 10000);
    EXPECT_EQ(holes, 0) << (smooth ? "smooth" : "flat");
  }
}

TEST(RenderTest, SideFacingTheKeyLightIsBrighter) {
  const TriangleMesh mesh = icosphere(4);
  const RenderOptions options = plain_options(400, 300);
  const Image image = render_mesh(mesh, options);
  const Disc disc = projected_sphere(frame_camera(mesh, options), 1.0f);
  // The key light shines from the viewer's upper left.
  const int offset = int(0.45 * disc.radius);
  const double lit = mean_luminance(image, int(disc.x) - offset, int(disc.y) - offset, 3);
  const double shaded = mean_luminance(image, int(disc.x) + offset, int(disc.y) + offset, 3);
  EXPECT_GT(lit, 1.3 * shaded) << "upper left " << lit << ", lower right " << shaded;
}

TEST(RenderTest, BackFacesAreDrawnDimmer) {
  // A square facing +x, seen head-on from +x (yaw 0, pitch 0); then the same with reversed winding.
  TriangleMesh front;
  front.vertices = {{0, -1, -1}, {0, 1, -1}, {0, 1, 1}, {0, -1, 1}};
  front.triangles = {{0, 1, 2}, {0, 2, 3}};
  TriangleMesh back = front;
  for (Triangle& t : back.triangles) std::swap(t[1], t[2]);
  RenderOptions options = plain_options(200, 200);
  options.yaw_degrees = 0;
  options.pitch_degrees = 0;
  const Image seen_front = render_mesh(front, options), seen_back = render_mesh(back, options);
  const Rgb background = to_bytes(options.background_top);
  EXPECT_NE(pixel(seen_front, 100, 100), background);
  EXPECT_NE(pixel(seen_back, 100, 100), background);
  EXPECT_LT(mean_luminance(seen_back, 100, 100, 5), 0.8 * mean_luminance(seen_front, 100, 100, 5));
}

TEST(RenderTest, RgbColourAttributeColoursTheSurface) {
  TriangleMesh mesh = icosphere(3);
  Attribute color{"color", 3, false, {}};
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) color.values.insert(color.values.end(), {1.0f, 0.0f, 0.0f});
  mesh.attributes.push_back(color);
  RenderOptions options = plain_options();
  options.color_attribute = "color";
  const Image image = render_mesh(mesh, options);
  const Rgb background = to_bytes(options.background_top);
  int covered = 0, red = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const Rgb c = pixel(image, x, y);
      if (c == background) continue;
      ++covered;
      red += c.r > c.g + 40 && c.r > c.b + 40;
    }
  ASSERT_GT(covered, 1000);
  EXPECT_GT(double(red) / covered, 0.9);

  // An unknown attribute name is refused, naming the attributes the mesh has.
  options.color_attribute = "no such attribute";
  try {
    (void)render_mesh(mesh, options);
    ADD_FAILURE() << "an unknown colour attribute was accepted";
  } catch (const InvalidParameter& e) {
    EXPECT_NE(std::string(e.what()).find("no such attribute"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("color (3 components)"), std::string::npos) << e.what();
  }
}

TEST(RenderTest, ScalarAttributeIsMappedThroughTheColormap) {
  TriangleMesh mesh = icosphere(4);
  Attribute height{"height", 1, false, {}};
  for (const Vec3f& v : mesh.vertices) height.values.push_back(v.z);
  mesh.attributes.push_back(height);
  RenderOptions options = plain_options(400, 300);
  options.color_attribute = "height";
  const Image image = render_mesh(mesh, options);
  const Disc disc = projected_sphere(frame_camera(mesh, options), 1.0f);
  // Viridis runs from purple (low: blue > green) to yellow (high: green ≫ blue).
  const Rgb top = pixel(image, int(disc.x), int(disc.y - 0.8 * disc.radius));
  const Rgb bottom = pixel(image, int(disc.x), int(disc.y + 0.8 * disc.radius));
  EXPECT_GT(top.g, top.b + 60);
  EXPECT_GT(bottom.b, bottom.g);
}

TEST(RenderTest, EmptyMeshGivesBackgroundOnly) {
  const RenderOptions plain = plain_options(64, 48);
  const Image image = render_mesh(TriangleMesh{}, plain);
  ASSERT_EQ(image.rgb.size(), std::size_t(64 * 48 * 3));
  const Rgb background = to_bytes(plain.background_top);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) ASSERT_EQ(pixel(image, x, y), background) << x << ", " << y;

  // With the gradient: every row uniform, rows getting darker downwards.
  RenderOptions gradient = plain;
  gradient.background_gradient = true;
  const Image graded = render_mesh(TriangleMesh{}, gradient);
  for (int y = 0; y < graded.height; ++y) {
    for (int x = 1; x < graded.width; ++x) ASSERT_EQ(pixel(graded, x, y), pixel(graded, 0, y));
    if (y > 0) {
      ASSERT_LE(luminance(pixel(graded, 0, y)), luminance(pixel(graded, 0, y - 1)));
    }
  }
  EXPECT_GT(luminance(pixel(graded, 0, 0)), luminance(pixel(graded, 0, graded.height - 1)) + 20);
}

TEST(RenderTest, ParticlesAreDepthTestedAgainstTheSurface) {
  const TriangleMesh mesh = icosphere(4);
  RenderOptions options = plain_options();
  options.particle_radius_pixels = 3;
  const Image without = render_mesh(mesh, options);
  const Camera camera = frame_camera(mesh, options);

  // A particle at the centre of the sphere is hidden by the surface.
  ParticleSet hidden;
  hidden.positions = {{0, 0, 0}};
  options.particles = &hidden;
  EXPECT_EQ(render_mesh(mesh, options).rgb, without.rgb);

  // One floating between the sphere and the camera is drawn, in its own colour.
  ParticleSet visible;
  const Vec3f position = camera.target + normalized(camera.eye - camera.target) * 1.3f;
  visible.positions = {position};
  options.particles = &visible;
  const Image with = render_mesh(mesh, options);
  const Vec3f at = project(camera, position);
  const Rgb dot = pixel(with, int(at.x), int(at.y));
  EXPECT_NE(dot, pixel(without, int(at.x), int(at.y)));
  EXPECT_GT(dot.r, dot.b + 60);  // orange on blue water
}

TEST(RenderTest, SameBytesWhateverTheThreadCount) {
  TriangleMesh mesh = icosphere(5);
  mesh.normals.clear();
  const Image parallel = render_mesh(mesh);
  Image serial;
  tbb::task_arena one_thread(1);
  one_thread.execute([&] { serial = render_mesh(mesh); });
  EXPECT_EQ(parallel.rgb, serial.rgb);
}

TEST(RenderTest, RejectsInvalidInput) {
  const TriangleMesh sphere = icosphere(1);
  RenderOptions options;
  options.width = 0;
  EXPECT_THROW(render_mesh(sphere, options), InvalidParameter);
  options = {};
  options.pitch_degrees = 95;
  EXPECT_THROW(render_mesh(sphere, options), InvalidParameter);
  options = {};
  options.up = {0, 0, 0};
  EXPECT_THROW(render_mesh(sphere, options), InvalidParameter);
  options = {};
  options.base_color = {1.5f, 0, 0};
  EXPECT_THROW(render_mesh(sphere, options), InvalidParameter);

  TriangleMesh bad_index = sphere;
  bad_index.triangles.push_back({0, 1, uint32_t(sphere.vertices.size())});
  EXPECT_THROW(render_mesh(bad_index), InvalidParameter);
  TriangleMesh bad_normals = sphere;
  bad_normals.normals.pop_back();
  EXPECT_THROW(render_mesh(bad_normals), InvalidParameter);
}

// ---------------------------------------------------------------------------------------------

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

uint32_t big_endian(const std::vector<unsigned char>& bytes, std::size_t at) {
  return uint32_t(bytes[at]) << 24 | uint32_t(bytes[at + 1]) << 16 | uint32_t(bytes[at + 2]) << 8 |
         uint32_t(bytes[at + 3]);
}

// --- the up axis ------------------------------------------------------------------------------

/// A pool: a slab `depth` deep along `up` on a floor at 0, `width` wide along the other axes,
/// and a few droplets above it (a splash), on a lattice of spacing 1.
std::vector<Vec3f> pool(int up, int width, int depth) {
  std::vector<Vec3f> points;
  for (int i = 0; i < width; ++i)
    for (int j = 0; j < width; ++j)
      for (int k = 0; k < depth; ++k) {
        Vec3f p{};
        p[up] = float(k), p[(up + 1) % 3] = float(i), p[(up + 2) % 3] = float(j);
        points.push_back(p);
      }
  for (int drop = 0; drop < 20; ++drop) {
    Vec3f p{};
    p[up] = float(3 * depth + drop), p[(up + 1) % 3] = float(drop % width), p[(up + 2) % 3] = 1;
    points.push_back(p);
  }
  return points;
}

Attribute velocities(std::size_t n, Vec3f v) {
  Attribute a{"velocity", 3, false, {}};
  for (std::size_t i = 0; i < n; ++i) a.values.insert(a.values.end(), {v.x, v.y, v.z});
  return a;
}

TEST(UpAxis, HoudiniFilesAreYUpWhateverThePointsShow) {
  const std::vector<Vec3f> points = pool(2, 10, 3);
  for (const char* format : {"bgeo", "bgeo (binary JSON)", "bgeo.sc"}) {
    const UpAxis up = guess_up_axis(points, nullptr, format);
    EXPECT_EQ(up.axis, 1) << format;
    EXPECT_NE(up.reason.find("Houdini"), std::string::npos) << up.reason;
  }
  EXPECT_EQ(guess_up_axis(points, nullptr, "ply (binary little endian)").axis, 2);
}

TEST(UpAxis, APoolSettlesLowAlongItsUpAxis) {
  for (int axis = 0; axis < 3; ++axis) {
    const UpAxis up = guess_up_axis(pool(axis, 12, 3), nullptr, "csv");
    EXPECT_EQ(up.axis, axis) << up.reason;
    EXPECT_NE(up.reason.find("settle low"), std::string::npos) << up.reason;
    EXPECT_EQ(up.direction()[axis], 1.0f);
  }
}

TEST(UpAxis, GravityShowsInTheVelocities) {
  // A ball of particles with no lower side, falling along -x and drifting along +z.
  std::vector<Vec3f> ball;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j)
      for (int k = -5; k <= 5; ++k)
        if (i * i + j * j + k * k <= 25) ball.push_back({float(i), float(j), float(k)});
  const Attribute falling = velocities(ball.size(), {-2, 0, 0.5f});
  const UpAxis up = guess_up_axis(ball, &falling, "vtk");
  EXPECT_EQ(up.axis, 0) << up.reason;
  EXPECT_NE(up.reason.find("move down x"), std::string::npos) << up.reason;
  // Rising, or at rest, a ball shows nothing: the default.
  const Attribute rising = velocities(ball.size(), {2, 0, 0});
  EXPECT_EQ(guess_up_axis(ball, &rising, "vtk").axis, 2);
  const Attribute still = velocities(ball.size(), {0, 0, 0});
  const UpAxis none = guess_up_axis(ball, &still, "vtk");
  EXPECT_EQ(none.axis, 2);
  EXPECT_NE(none.reason.find("default"), std::string::npos) << none.reason;
}

TEST(UpAxis, NoPointsOrNonFiniteOnesGiveTheDefault) {
  EXPECT_EQ(guess_up_axis({}, nullptr, "").axis, 2);
  std::vector<Vec3f> points = pool(1, 10, 3);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  points.push_back({nan, 0, 0});
  points.push_back({0, std::numeric_limits<float>::infinity(), 0});
  EXPECT_EQ(guess_up_axis(points, nullptr, "").axis, 1);
}

TEST(RenderPngTest, WritesPngWithHeaderAndPixels) {
  Image image;
  image.width = 37;
  image.height = 23;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      image.rgb.insert(image.rgb.end(), {uint8_t(x * 7), uint8_t(y * 11), uint8_t((x + y) % 2 ? 255 : 0)});
  const test::TempDir dir;
  const std::string path = dir.file("preview.png");
  write_png(path, image);

  const std::vector<unsigned char> bytes = read_bytes(path);
  ASSERT_GT(bytes.size(), 33u);
  const std::array<unsigned char, 8> signature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(std::equal(signature.begin(), signature.end(), bytes.begin()));
  EXPECT_EQ(std::string(bytes.begin() + 12, bytes.begin() + 16), "IHDR");
  EXPECT_EQ(big_endian(bytes, 16), 37u);
  EXPECT_EQ(big_endian(bytes, 20), 23u);
  EXPECT_EQ(bytes[24], 8);  // bit depth
  EXPECT_EQ(bytes[25], 2);  // colour type: RGB

  // Decodes to exactly the pixels written.
  const Image decoded = test::decode_png(bytes);
  ASSERT_GT(decoded.width, 0) << "not a decodable PNG";
  EXPECT_EQ(decoded.width, 37);
  EXPECT_EQ(decoded.height, 23);
  EXPECT_EQ(decoded.rgb, image.rgb);

  // Nothing but the target is left in the directory (the temporary file was renamed).
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path), std::filesystem::directory_iterator()), 1);
}

TEST(RenderPngTest, MissingDirectoryThrowsIoErrorAndLeavesNoFile) {
  const test::TempDir dir;
  const std::string path = dir.file("no-such-directory/preview.png");
  Image image;
  image.width = image.height = 4;
  image.rgb.assign(4 * 4 * 3, 128);
  try {
    write_png(path, image);
    FAIL() << "write_png into a missing directory did not throw";
  } catch (const IoError& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
}

TEST(RenderPngTest, RejectsInconsistentImage) {
  const test::TempDir dir;
  Image image;
  image.width = 4;
  image.height = 4;
  image.rgb.assign(10, 0);
  EXPECT_THROW(write_png(dir.file("bad.png"), image), InvalidParameter);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
}

}  // namespace
}  // namespace meniscus
