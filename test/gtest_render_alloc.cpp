// No heap allocation inside a rendered frame (issue 13): a mesh robot with markers, link
// frames and the text overlay, one thread and two, the rgb8 copy, a camera that moves. Every
// allocation is counted: operator new/delete and the C allocator are replaced (the same hooks
// as gtest_alloc.cpp: Eigen and Cairo allocate with malloc).
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "se3_sim/render/camera_sensor.h"
#include "se3_sim/render/render.h"
#include "source_paths.h"

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}

namespace {
std::atomic<long> g_allocations{0};
inline void count() {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(std::size_t n) {
  count();
  return __libc_malloc(n);
}
void* calloc(std::size_t k, std::size_t n) {
  count();
  return __libc_calloc(k, n);
}
void* realloc(void* p, std::size_t n) {
  count();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t a, std::size_t n) {
  count();
  return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  count();
  return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
  count();
  void* p = __libc_memalign(a, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void free(void* p) {
  __libc_free(p);
}
}

namespace {
void* new_or_throw(std::size_t n) {
  if (void* p = __libc_malloc(n == 0 ? 1 : n)) {
    count();
    return p;
  }
  throw std::bad_alloc();
}
void* new_aligned_or_throw(std::size_t n, std::align_val_t a) {
  if (void* p = __libc_memalign(static_cast<std::size_t>(a), n == 0 ? 1 : n)) {
    count();
    return p;
  }
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) {
  return new_or_throw(n);
}
void* operator new[](std::size_t n) {
  return new_or_throw(n);
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  count();
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  count();
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return new_aligned_or_throw(n, a);
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return new_aligned_or_throw(n, a);
}
void operator delete(void* p) noexcept {
  __libc_free(p);
}
void operator delete[](void* p) noexcept {
  __libc_free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  __libc_free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  __libc_free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  __libc_free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  __libc_free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  __libc_free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  __libc_free(p);
}

using namespace se3;
using namespace se3::render;

namespace {

template <class F>
long allocations_of(F&& f) {
  const long before = g_allocations.load();
  f();
  return g_allocations.load() - before;
}

}  // namespace

TEST(RenderAlloc, FramesWithOverlayMarkersAndThreadsAllocateNothing) {
  const std::string urdf = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
  const Model m = model_from_urdf_file(urdf);
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  go.paths.use_ros_package_path = false;
  const GeometryModel g = geometry_from_urdf_file(m, urdf, go);
  ASSERT_TRUE(g.warnings.empty());
  Data d(m);
  std::vector<Marker> markers(6);
  markers[0].type = Marker::Type::Box;
  markers[0].a = Vec3(0.3, 0.3, 0.1);
  markers[1].type = Marker::Type::Arrow;
  markers[1].b = Vec3(0.4, 0, 0.2);
  markers[2].type = Marker::Type::Point;
  markers[2].a = Vec3(0.1, -0.2, 0.3);
  markers[3].type = Marker::Type::Line;
  markers[3].b = Vec3(0, 0, 0.8);
  markers[4].type = Marker::Type::Sphere;
  markers[4].a = Vec3(0, 0.3, 0.5);
  markers[5].type = Marker::Type::Cylinder;  // a scene object's cylinder (or capsule's middle)
  markers[5].a = Vec3(-0.3, 0.2, 0.3);
  markers[5].size3 = Vec3(0.1, 0.1, 0.3);
  Overlay ov;
  ov.sim_time = 1.0;
  ov.real_time_factor = 0.99;
  ov.joint = "panda_joint4";
  ov.torque = -1.5;
  ov.lines = {"paused", "a status line of some length"};
  for (int threads : {1, 2}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    Camera cam;
    cam.eye = Vec3(1.6, -1.4, 1.0);
    cam.target = Vec3(0, 0, 0.45);
    Renderer r(cam);
    r.style().threads = threads;
    r.style().frames = true;
    r.set_model(m, g);
    std::vector<uint8_t> rgb(std::size_t(cam.width) * cam.height * 3);
    VecX q = VecX::Zero(m.n);
    forward_kinematics(m, d, SE3(), q);
    r.render(d.oMb, markers, ov);  // the first frame may start the helper thread
    r.copy_rgb8(rgb.data());
    // The counter sees both kinds of allocation.
    EXPECT_GE(allocations_of([] { std::vector<int> v(3, 1); }), 1);
    EXPECT_GE(allocations_of([] { free(malloc(16)); }), 1);
    for (int k = 0; k < 6; ++k) {
      q.setConstant(0.1 * k);
      forward_kinematics(m, d, SE3(), q);
      ov.sim_time = 1.0 + k;
      if (k == 3) {  // the camera moves: background redrawn
        cam.eye.x() += 0.1;
        r.set_camera(cam);
      }
      EXPECT_EQ(allocations_of([&] {
                  r.render(d.oMb, markers, ov);
                  r.copy_rgb8(rgb.data());
                }),
                0)
          << "frame " << k;
    }
    EXPECT_GT(r.last_triangles(), 10000u);
  }
}

// A depth camera on the Panda's hand (issue 38): rgb8, depth and the cloud of each frame from
// buffers allocated once, while the camera moves with the hand.
TEST(RenderAlloc, CameraSensorFramesAllocateNothing) {
  const std::string urdf = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
  const Model m = model_from_urdf_file(urdf);
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  go.paths.use_ros_package_path = false;
  const GeometryModel g = geometry_from_urdf_file(m, urdf, go);
  Data d(m);
  std::vector<Marker> objects(1);
  objects[0].type = Marker::Type::Box;
  objects[0].a = Vec3(0.6, 0, 0.025);
  objects[0].size3 = Vec3(0.6, 1.2, 0.05);
  CameraSensorSpec spec;
  spec.width = 320;
  spec.height = 240;
  CameraSensor cam(spec);
  cam.set_model(m, g);
  VecX q = VecX::Zero(m.n);
  forward_kinematics(m, d, SE3(), q);
  const SE3 eye(Mat3::Identity(), Vec3(1.5, 0, 0.8));
  const Mat3 look = Eigen::AngleAxisd(M_PI, Vec3::UnitZ()).toRotationMatrix() *
                    Eigen::AngleAxisd(0.4, Vec3::UnitY()).toRotationMatrix();
  cam.render(SE3(look * optical_in_body(), eye.p), d.oMb, objects);
  for (int k = 0; k < 4; ++k) {
    q.setConstant(0.1 * k);
    forward_kinematics(m, d, SE3(), q);
    const SE3 moved(look * optical_in_body(), eye.p + Vec3(0, 0.05 * k, 0));
    EXPECT_EQ(allocations_of([&] { cam.render(moved, d.oMb, objects); }), 0) << "frame " << k;
  }
  // Depth alone, and colour again (the background redrawn), allocate nothing either.
  for (int k = 0; k < 4; ++k) {
    cam.set_color(k % 2 == 1);
    EXPECT_EQ(
        allocations_of([&] { cam.render(SE3(look * optical_in_body(), eye.p), d.oMb, objects); }),
        0)
        << "depth-only frame " << k;
  }
  int hits = 0;
  for (float z : cam.depth()) hits += std::isfinite(z);
  EXPECT_GT(hits, 1000);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
