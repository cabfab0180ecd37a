// Camera sensors (issue 38): depth against the analytic distance to a box's face, NaN for the
// sky and beyond the far clip, the organized cloud on the face's plane, the ground's depth, and
// CameraInfo's K putting a box's edges on the pixels the RGB image shows them in.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "se3_sim/render/camera_sensor.h"

using namespace se3;
using namespace se3::render;

namespace {

// A level camera 1 m above the ground at the origin looking along world +x; a 1 m box centred
// at (3, 0, 1): its face x = 2.5 faces the camera, so every face pixel is 2.5 m deep.
constexpr double kFace = 2.5;

SE3 optical_pose() {
  return SE3(optical_in_body(), Vec3(0, 0, 1));
}

std::vector<Marker> the_box() {
  Marker m;
  m.type = Marker::Type::Box;
  m.a = Vec3(3, 0, 1);
  m.size3 = Vec3(1, 1, 1);
  m.color = Eigen::Vector3d(0.9, 0.1, 0.1);
  return {m};
}

CameraSensorSpec odd_spec() {
  CameraSensorSpec s;
  s.width = 321;  // odd: the centre pixel's ray is the optical axis
  s.height = 241;
  s.hfov = 1.0;
  s.near = 0.05;
  s.far = 10;
  s.ground = false;
  return s;
}

// Pixel of an optical-frame point through K (centres at integers).
Vec2 through_k(const CameraIntrinsics& c, const Vec3& x) {
  return Vec2(c.K[0] * x.x() / x.z() + c.K[2], c.K[4] * x.y() / x.z() + c.K[5]);
}

}  // namespace

TEST(CameraSensor, IntrinsicsMatchTheImage) {
  const CameraSensorSpec s = odd_spec();
  const CameraIntrinsics c = camera_intrinsics(s);
  EXPECT_EQ(c.width, 321);
  EXPECT_EQ(c.height, 241);
  EXPECT_NEAR(c.fx, 160.5 / std::tan(0.5), 1e-9);
  EXPECT_EQ(c.fx, c.fy);
  EXPECT_EQ(c.cx, 160.0);
  EXPECT_EQ(c.cy, 120.0);
  EXPECT_EQ(c.P[3], 0.0);
  EXPECT_EQ(c.P[2], c.K[2]);
  EXPECT_EQ(c.P[10], 1.0);
  // Optical axes in the REP 103 body: z forward = body x, x right = -body y, y down = -body z.
  const Mat3 R = optical_in_body();
  EXPECT_TRUE(R.col(2).isApprox(Vec3::UnitX()));
  EXPECT_TRUE(R.col(0).isApprox(-Vec3::UnitY()));
  EXPECT_TRUE(R.col(1).isApprox(-Vec3::UnitZ()));
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
  std::string err;
  EXPECT_TRUE(check_camera_spec(s, &err));
  CameraSensorSpec bad = s;
  bad.far = 0.01;
  EXPECT_FALSE(check_camera_spec(bad, &err));
  EXPECT_NE(err.find("far"), std::string::npos);
  bad = s;
  bad.hfov = 4;
  EXPECT_FALSE(check_camera_spec(bad, &err));
  EXPECT_NE(err.find("horizontal_fov"), std::string::npos);
}

TEST(CameraSensor, DepthOfABoxFaceSkyNaNAndCloudOnThePlane) {
  const CameraSensorSpec s = odd_spec();
  CameraSensor cam(s);
  cam.render(optical_pose(), {}, the_box());
  const CameraIntrinsics& c = cam.intrinsics();
  const int W = s.width, H = s.height;
  ASSERT_EQ(cam.depth().size(), std::size_t(W) * H);
  ASSERT_EQ(cam.cloud().size(), std::size_t(W) * H * 4);
  ASSERT_EQ(cam.rgb().size(), std::size_t(W) * H * 3);
  // The face's image: optical x = -y_world in [-0.5, 0.5], y = 1 - z_world in [-0.5, 0.5].
  const Vec2 lo = through_k(c, Vec3(-0.5, -0.5, kFace)), hi = through_k(c, Vec3(0.5, 0.5, kFace));
  int face = 0, sky = 0;
  for (int j = 0; j < H; ++j) {
    for (int i = 0; i < W; ++i) {
      const std::size_t k = std::size_t(j) * W + i;
      const float d = cam.depth()[k];
      const float* p = &cam.cloud()[4 * k];
      const bool inside = i > lo.x() + 1 && i < hi.x() - 1 && j > lo.y() + 1 && j < hi.y() - 1;
      const bool outside = i < lo.x() - 1 || i > hi.x() + 1 || j < lo.y() - 1 || j > hi.y() + 1;
      if (inside) {
        ++face;
        ASSERT_NEAR(d, kFace, 1e-4 * kFace) << i << " " << j;
        ASSERT_NEAR(p[2], kFace, 1e-4 * kFace) << i << " " << j;  // on the plane z = 2.5
        // and on the pixel's ray
        ASSERT_NEAR(p[0], (i - c.cx) / c.fx * p[2], 1e-6);
        ASSERT_NEAR(p[1], (j - c.cy) / c.fy * p[2], 1e-6);
        ASSERT_GT(cam.rgb()[3 * k], cam.rgb()[3 * k + 1] + 40);  // the box's red, not the sky
      } else if (outside) {
        ++sky;
        ASSERT_TRUE(std::isnan(d)) << i << " " << j << " " << d;
        ASSERT_TRUE(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]));
      }
    }
  }
  EXPECT_GT(face, 3000);
  EXPECT_GT(sky, 30000);
  // Every pixel, the SIMD columns and the scalar remainder alike (321 = 4 * 80 + 1), is the
  // depth buffer's 1 / iz and its ray's point, bit for bit.
  const float* zbuf = cam.renderer().framebuffer().depth();
  for (int j = 0; j < H; ++j) {
    const float b = float((j - c.cy) / c.fy);
    for (int i = 0; i < W; ++i) {
      const std::size_t k = std::size_t(j) * W + i;
      const float a = float((i - c.cx) / c.fx);
      const float d = cam.depth()[k];
      if (zbuf[k] > 0) {
        ASSERT_EQ(d, 1.0f / zbuf[k]) << i << " " << j;
        ASSERT_EQ(cam.cloud()[4 * k], a * d) << i << " " << j;
        ASSERT_EQ(cam.cloud()[4 * k + 1], b * d) << i << " " << j;
      } else {
        ASSERT_TRUE(std::isnan(d)) << i << " " << j;
      }
    }
  }
  // The centre pixel is (0, 0, d) in the optical frame.
  const std::size_t centre = std::size_t(120) * W + 160;
  EXPECT_EQ(cam.cloud()[4 * centre + 0], 0.0f);
  EXPECT_EQ(cam.cloud()[4 * centre + 1], 0.0f);
  EXPECT_NEAR(cam.cloud()[4 * centre + 2], kFace, 1e-4 * kFace);
  // The cloud's colour is the image's.
  uint32_t rgb;
  std::memcpy(&rgb, &cam.cloud()[4 * centre + 3], 4);
  EXPECT_EQ(rgb >> 16, cam.rgb()[3 * centre]);
  EXPECT_EQ((rgb >> 8) & 0xff, cam.rgb()[3 * centre + 1]);
  EXPECT_EQ(rgb & 0xff, cam.rgb()[3 * centre + 2]);
}

// Where the box is not 2.5 m away the face pixel colour check above would not hold: beyond the
// far clip every pixel is NaN.
TEST(CameraSensor, BeyondTheFarClipIsNaN) {
  CameraSensorSpec s = odd_spec();
  s.far = 2.0;
  CameraSensor cam(s);
  cam.render(optical_pose(), {}, the_box());
  for (float d : cam.depth()) ASSERT_TRUE(std::isnan(d));
}

TEST(CameraSensor, GroundDepthIsTheRaysIntersection) {
  CameraSensorSpec s = odd_spec();
  s.ground = true;
  CameraSensor cam(s);
  cam.render(optical_pose(), {}, {});
  const CameraIntrinsics& c = cam.intrinsics();
  // Below the centre row the level ray (a, b, 1) reaches z = 0 at depth 1 / b (eye 1 m high);
  // above it (sky) nothing.
  for (int j : {0, 60, 119, 120})
    EXPECT_TRUE(std::isnan(cam.depth()[std::size_t(j) * s.width + 7]));
  for (int j : {140, 200, 240}) {
    const double b = (j - c.cy) / c.fy;
    const double want = 1.0 / b;
    const float d = cam.depth()[std::size_t(j) * s.width + 7];
    if (want > s.far) {
      EXPECT_TRUE(std::isnan(d));
    } else {
      EXPECT_NEAR(d, want, 1e-6 * want) << j;
    }
  }
}

// K's pixels are the image's: the box's left and top edges, projected through K, are where the
// RGB image's box begins (pixel centres at integers: the first column inside is ceil(u)).
TEST(CameraSensor, KReprojectsTheBoxCornerToItsPixel) {
  // A box off-centre so that its edges fall between pixel centres.
  CameraSensorSpec s = odd_spec();
  s.width = 320;  // even sizes too
  s.height = 240;
  CameraSensor cam(s);
  std::vector<Marker> box = the_box();
  box[0].a = Vec3(3, 0.19, 1.13);
  cam.render(optical_pose(), {}, box);
  const CameraIntrinsics& c = cam.intrinsics();
  // The near face's corner at world (2.5, 0.69, 1.63): optical (-0.69, -0.63, 2.5), the
  // top-left corner of the face in the image; the opposite one at (0.31, 0.37, 2.5).
  const Vec2 corner = through_k(c, Vec3(-0.69, -0.63, kFace));
  const Vec2 other = through_k(c, Vec3(0.31, 0.37, kFace));
  for (double v : {corner.x(), corner.y(), other.x(), other.y()}) {
    // Away from pixel centres and from half-way between them: K off by half a pixel (the
    // other convention) would move every edge by one pixel.
    const double f = v - std::floor(v);
    ASSERT_TRUE(f > 0.6 && f < 0.9) << v;
  }
  auto red = [&](int i, int j) {
    const uint8_t* p = &cam.rgb()[3 * (std::size_t(j) * s.width + i)];
    return p[0] > p[1] + 40;
  };
  const int i0 = int(std::ceil(corner.x())), j0 = int(std::ceil(corner.y()));
  const int i1 = int(std::floor(other.x())), j1 = int(std::floor(other.y()));
  const int jm = (j0 + j1) / 2, im = (i0 + i1) / 2;
  EXPECT_TRUE(red(i0, jm));
  EXPECT_FALSE(red(i0 - 1, jm));
  EXPECT_TRUE(red(i1, jm));
  EXPECT_FALSE(red(i1 + 1, jm));
  EXPECT_TRUE(red(im, j0));
  EXPECT_FALSE(red(im, j0 - 1));
  EXPECT_TRUE(red(im, j1));
  EXPECT_FALSE(red(im, j1 + 1));
  // The corner pixel itself.
  EXPECT_TRUE(red(i0, j0));
  EXPECT_FALSE(red(i0 - 1, j0 - 1));
}

// A depth camera without colour draws the same depth and points, bit for bit, as one with it
// (box faces large and small triangles of a sphere, the ground), its cloud's rgb 0; switched
// back on it draws the colour image a colour camera draws.
TEST(CameraSensor, DepthOnlyGivesTheSameDepthBitForBit) {
  CameraSensorSpec s = odd_spec();
  s.ground = true;
  std::vector<Marker> scene = the_box();
  Marker ball;
  ball.type = Marker::Type::Sphere;
  ball.a = Vec3(2.0, -0.6, 0.4);
  ball.size = 0.3;
  scene.push_back(ball);
  scene[0].R = Eigen::AngleAxisd(0.3, Vec3::UnitZ()).toRotationMatrix();
  const SE3 pose(optical_in_body() * Eigen::AngleAxisd(0.1, Vec3::UnitX()).toRotationMatrix(),
                 Vec3(0, 0.1, 1));
  CameraSensor colour(s);
  s.color = false;
  CameraSensor depth_only(s);
  EXPECT_FALSE(depth_only.color());
  for (int frame = 0; frame < 2; ++frame) {  // the first frame and one over a cached background
    colour.render(pose, {}, scene);
    depth_only.render(pose, {}, scene);
    const std::size_t n = colour.depth().size();
    ASSERT_EQ(std::memcmp(colour.depth().data(), depth_only.depth().data(), 4 * n), 0);
    int hits = 0;
    for (std::size_t k = 0; k < n; ++k) {
      hits += std::isfinite(colour.depth()[k]);
      for (int c = 0; c < 3; ++c) {
        const float a = colour.cloud()[4 * k + c], b = depth_only.cloud()[4 * k + c];
        ASSERT_TRUE(std::memcmp(&a, &b, 4) == 0) << k;
      }
      uint32_t rgb;
      std::memcpy(&rgb, &depth_only.cloud()[4 * k + 3], 4);
      ASSERT_EQ(rgb, 0u) << k;
    }
    EXPECT_GT(hits, 20000);
  }
  depth_only.set_color(true);
  depth_only.render(pose, {}, scene);
  EXPECT_EQ(depth_only.rgb(), colour.rgb());
  EXPECT_EQ(
      std::memcmp(colour.cloud().data(), depth_only.cloud().data(), 4 * colour.cloud().size()), 0);
}

// The rgb8 image is the framebuffer's colours, the same bytes whether it is written with the
// depth and cloud (one pass) or without depth; an odd width leaves a row tail past the last
// group of eight.
TEST(CameraSensor, RgbIsTheFramebufferWithOrWithoutDepth) {
  CameraSensorSpec s = odd_spec();
  s.ground = true;
  const SE3 pose(optical_in_body() * Eigen::AngleAxisd(0.1, Vec3::UnitX()).toRotationMatrix(),
                 Vec3(0, 0.1, 1));
  CameraSensor with_depth(s);
  s.depth = false;
  CameraSensor rgb_only(s);
  for (int frame = 0; frame < 2; ++frame) {
    with_depth.render(pose, {}, the_box());
    rgb_only.render(pose, {}, the_box());
    ASSERT_EQ(with_depth.rgb(), rgb_only.rgb());
    const Renderer& r = with_depth.renderer();
    int boxed = 0;
    for (int y = 0; y < s.height; ++y) {
      for (int x = 0; x < s.width; ++x) {
        const Rgb q = r.framebuffer().rgb(x, y);
        const uint8_t* p = &with_depth.rgb()[3 * (std::size_t(y) * s.width + x)];
        ASSERT_EQ(int(p[0]), int(q.r)) << x << " " << y;
        ASSERT_EQ(int(p[1]), int(q.g)) << x << " " << y;
        ASSERT_EQ(int(p[2]), int(q.b)) << x << " " << y;
        boxed += q.r > q.g + 60;
      }
    }
    EXPECT_GT(boxed, 5000) << "the red box is in the image";
  }
}

// A width of whole groups of eight takes the fused AVX2 pass, for which the renderer does not
// restore the background's colours: where a box stood in the last frame, the next frame's
// image, depth and cloud are a fresh camera's, and its image is an RGB-only camera's (which
// restores them).
TEST(CameraSensor, WhereABoxWasTheNextFrameShowsTheBackground) {
  CameraSensorSpec s = odd_spec();
  s.width = 320;
  s.ground = true;
  const SE3 pose(optical_in_body() * Eigen::AngleAxisd(0.1, Vec3::UnitX()).toRotationMatrix(),
                 Vec3(0, 0.1, 1));
  std::vector<Marker> moved = the_box();
  moved[0].a.y() = 0.7;
  moved[0].color = Eigen::Vector3d(0.1, 0.8, 0.2);
  CameraSensor camera(s);
  CameraSensorSpec rgb_spec = s;
  rgb_spec.depth = false;
  CameraSensor rgb_only(rgb_spec);
  const std::vector<std::vector<Marker>> scenes = {the_box(), moved, {}, the_box()};
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    camera.render(pose, {}, scenes[k]);
    rgb_only.render(pose, {}, scenes[k]);
    CameraSensor fresh(s);
    fresh.render(pose, {}, scenes[k]);
    EXPECT_EQ(camera.rgb(), fresh.rgb()) << "scene " << k;
    EXPECT_EQ(camera.rgb(), rgb_only.rgb()) << "scene " << k;
    EXPECT_EQ(std::memcmp(camera.depth().data(), fresh.depth().data(), 4 * camera.depth().size()),
              0)
        << "scene " << k;
    EXPECT_EQ(std::memcmp(camera.cloud().data(), fresh.cloud().data(), 4 * camera.cloud().size()),
              0)
        << "scene " << k;
  }
  // The two boxes are where the test means them to be: red in the first, green in the second.
  camera.render(pose, {}, moved);
  int green = 0;
  for (std::size_t p = 0; p < camera.rgb().size(); p += 3) {
    green += camera.rgb()[p + 1] > camera.rgb()[p] + 60;
  }
  EXPECT_GT(green, 2000);
}

// CameraOutputs: the frame written into the caller's buffers (the node's messages) is the
// frame the camera writes into its own, on the fused path (width 320) and the other (321); the
// camera's own buffers are left as they were.
TEST(CameraSensor, OutputsGoWhereTheCallerSays) {
  for (const int width : {320, 321}) {
    CameraSensorSpec s = odd_spec();
    s.width = width;
    s.ground = true;
    const SE3 pose(optical_in_body() * Eigen::AngleAxisd(0.1, Vec3::UnitX()).toRotationMatrix(),
                   Vec3(0, 0.1, 1));
    CameraSensor own(s), theirs(s);
    const std::size_t n = std::size_t(s.width) * s.height;
    std::vector<uint8_t> rgb(3 * n, 7);
    std::vector<float> depth(n, 7.0f), cloud(4 * n, 7.0f);
    const std::vector<uint8_t> rgb_before = theirs.rgb();
    CameraOutputs out;
    out.rgb = rgb.data();
    out.depth = depth.data();
    out.cloud = cloud.data();
    for (int frame = 0; frame < 2; ++frame) {
      own.render(pose, {}, the_box());
      theirs.render(pose, {}, the_box(), out);
      EXPECT_EQ(rgb, own.rgb()) << width;
      EXPECT_EQ(std::memcmp(depth.data(), own.depth().data(), 4 * n), 0) << width;
      EXPECT_EQ(std::memcmp(cloud.data(), own.cloud().data(), 16 * n), 0) << width;
    }
    EXPECT_EQ(theirs.rgb(), rgb_before) << width;
    EXPECT_TRUE(std::isnan(theirs.depth()[n / 2])) << width;
  }
}

// A camera sees the ground plane, not the viewer's grid lines: looking down at the origin
// (where the grid's axes cross) every pixel is the background's colour.
TEST(CameraSensor, NoGridLinesInTheImage) {
  CameraSensorSpec s = odd_spec();
  s.ground = true;
  CameraSensor cam(s);
  const Mat3 down = (Mat3() << 1, 0, 0, 0, -1, 0, 0, 0, -1).finished();  // z down, x along x
  cam.render(SE3(down, Vec3(0.1, 0.2, 2.0)), {}, {});
  const Renderer& r = cam.renderer();
  for (int j = 0; j < s.height; ++j) {
    for (int i = 0; i < s.width; ++i) {
      const uint32_t want = r.background(i, j);
      const uint8_t* p = &cam.rgb()[3 * (std::size_t(j) * s.width + i)];
      ASSERT_EQ(p[0], want >> 16 & 0xff) << i << " " << j;
      ASSERT_EQ(p[1], want >> 8 & 0xff) << i << " " << j;
      ASSERT_EQ(p[2], want & 0xff) << i << " " << j;
    }
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
