// No heap allocation inside a time step. Every heap allocation is counted: global operator
// new/delete are replaced, and so is the C allocator (Eigen allocates its dynamic matrices with
// malloc, not with operator new), forwarding to glibc's own entry points. After Model and Data
// exist, the algorithms must not allocate.
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <random>

#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/world.h"
#include "source_paths.h"
#include "test_util.h"

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}

namespace {
std::atomic<long> g_allocations{0};
std::atomic<long> g_bytes{0};  // requested, never decreased by a free
inline void count(std::size_t bytes) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  g_bytes.fetch_add(static_cast<long>(bytes), std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(std::size_t n) {
  count(n);
  return __libc_malloc(n);
}
void* calloc(std::size_t k, std::size_t n) {
  count(k * n);
  return __libc_calloc(k, n);
}
void* realloc(void* p, std::size_t n) {
  count(n);
  return __libc_realloc(p, n);
}
void* memalign(std::size_t a, std::size_t n) {
  count(n);
  return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  count(n);
  return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
  count(n);
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
    count(n);
    return p;
  }
  throw std::bad_alloc();
}
void* new_aligned_or_throw(std::size_t n, std::align_val_t a) {
  if (void* p = __libc_memalign(static_cast<std::size_t>(a), n == 0 ? 1 : n)) {
    count(n);
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
  count(n);
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  count(n);
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

namespace {

// Allocations made by f().
template <class F>
long allocations_of(F&& f) {
  const long before = g_allocations.load();
  f();
  return g_allocations.load() - before;
}

// Bytes requested by f() (frees not subtracted).
template <class F>
long bytes_of(F&& f) {
  const long before = g_bytes.load();
  f();
  return g_bytes.load() - before;
}

// Allocations of 300 constrained steps of the scene's robot with free bodies and contacts given
// from outside, after 10 steps that may size what they need (-1 when one of those fails).
long steps_with_bodies_allocations(ConstraintSystem& cs, const Scene& sc, const Model& m,
                                   const ContactBodies& cb) {
  State x = scene_state(sc, m);
  auto stepper = make_stepper(sc.integrator, m);
  const VecX tau = VecX::Zero(m.nv);
  for (int k = 0; k < 10; ++k) {
    if (!constrained_step(cs, *stepper, x, tau, sc.dt, cb).ok) return -1;
  }
  return allocations_of([&] {
    for (int k = 0; k < 300; ++k) constrained_step(cs, *stepper, x, tau, sc.dt, cb);
  });
}

void check_no_allocation(const std::string& label, const Model& m) {
  SCOPED_TRACE(label);
  Data d(m);
  std::mt19937_64 rng(201);
  const se3_test::RandomState s = se3_test::random_state(m, rng);
  Vec6 fext;
  fext << 0.1, -0.2, 0.3, 1, 2, 3;
  // The counter sees both kinds of allocation: an Eigen VecX (malloc) and a std::vector (new).
  EXPECT_GE(allocations_of([&] {
              VecX x(m.nv);
              x.setZero();
              EXPECT_EQ(x.sum(), 0.0);
            }),
            1);
  EXPECT_GE(allocations_of([&] {
              std::vector<double> x(m.nv, 1.0);
              EXPECT_EQ(x.size(), static_cast<size_t>(m.nv));
            }),
            1);
  // From the first call on, each algorithm allocates nothing; crba and minv size the mass-matrix
  // workspaces on their first call (Data is O(n) until then), unless reserved ahead of it.
  for (int round = 0; round < 2; ++round) {
    if (round == 0) {
      EXPECT_EQ(d.M.size(), 0);
      EXPECT_EQ(d.Minv.size(), 0);
      EXPECT_GT(allocations_of([&] { crba(m, d, s.base, s.q); }), 0) << "first crba";
      EXPECT_GT(allocations_of([&] { minv(m, d, s.base, s.q); }), 0) << "first minv";
      Data reserved(m);
      reserved.reserve_crba(m);
      reserved.reserve_minv(m);
      EXPECT_EQ(allocations_of([&] { crba(m, reserved, s.base, s.q); }), 0) << "reserved crba";
      EXPECT_EQ(allocations_of([&] { minv(m, reserved, s.base, s.q); }), 0) << "reserved minv";
      EXPECT_EQ(reserved.M, d.M);
      EXPECT_EQ(reserved.Minv, d.Minv);
    }
    EXPECT_EQ(allocations_of([&] { forward_kinematics(m, d, s.base, s.q); }), 0) << "fk";
    EXPECT_EQ(allocations_of([&] { rnea(m, d, s.base, s.q, s.v, s.u); }), 0) << "rnea";
    EXPECT_EQ(allocations_of([&] { rnea(m, d, s.base, s.q, s.v, s.u, &fext); }), 0) << "rnea f";
    EXPECT_EQ(allocations_of([&] { aba(m, d, s.base, s.q, s.v, s.u); }), 0) << "aba";
    EXPECT_EQ(allocations_of([&] { aba(m, d, s.base, s.q, s.v, s.u, &fext); }), 0) << "aba f";
    EXPECT_EQ(allocations_of([&] { crba(m, d, s.base, s.q); }), 0) << "crba";
    EXPECT_EQ(allocations_of([&] { minv(m, d, s.base, s.q); }), 0) << "minv";
    EXPECT_EQ(allocations_of([&] { bias(m, d, s.base, s.q, s.v); }), 0) << "bias";
    EXPECT_EQ(allocations_of([&] { kinetic_energy(m, d, s.base, s.q, s.v); }), 0) << "T";
    EXPECT_EQ(allocations_of([&] { potential_energy(m, d, s.base, s.q); }), 0) << "V";
    EXPECT_EQ(allocations_of([&] { spatial_momentum(m, d, s.base, s.q, s.v); }), 0) << "h";
    EXPECT_EQ(allocations_of([&] { center_of_mass(m, d, s.base, s.q); }), 0) << "com";
  }
}

}  // namespace

TEST(Alloc, PandaFixed) {
  check_no_allocation("panda fixed",
                      model_from_urdf_file(se3_test::robot_path("panda.urdf"), UrdfOptions{}));
}

TEST(Alloc, Solo12Floating) {
  UrdfOptions opt;
  opt.floating = true;
  check_no_allocation("solo12 floating",
                      model_from_urdf_file(se3_test::robot_path("solo12.urdf"), opt));
}

TEST(Alloc, Chain50) {
  check_no_allocation("chain50 fixed", make_chain(50, false));
  check_no_allocation("chain50 floating", make_chain(50, true));
}

TEST(Alloc, RomeoFloating) {
  UrdfOptions opt;
  opt.floating = true;
  check_no_allocation("romeo floating",
                      model_from_urdf_file(se3_test::robot_path("romeo_small.urdf"), opt));
}

// collide() against the ground (hulls, boxes, cylinders, spheres: the half-space tests of the
// collision layer) and through FCL's broad phase allocates nothing after its first call. (Pairs
// FCL's narrow phase tests do allocate: its GJK makes its shape objects with new on every
// query, about 5 allocations per pair; docs/collision.md.)
TEST(Alloc, CollideOnTheGround) {
  const Scene s = load_scene(se3_sim_test::source_dir() + "/config/scenes/quadruped_ground.yaml");
  const Model m = scene_model(s);
  SceneCollision sc = scene_collision(s, &m);
  State x = scene_state(s, m);
  Data d(m);
  x.base.p.z() = 0.23;  // the feet and shins in the ground
  forward_kinematics(m, d, x.base, x.q);
  std::vector<SE3> frames;
  scene_frame_poses(d.oMb, {}, frames);
  CollisionData cd;
  collide(sc.model, cd, frames);
  EXPECT_GE(cd.contacts.size(), 8u);
  EXPECT_EQ(allocations_of([&] {
              for (int k = 0; k < 20; ++k) collide(sc.model, cd, frames);
            }),
            0);
  // Objects on the ground, apart from each other (only the broad phase sees their pairs).
  Scene o = parse_scene(
      "ground: true\nobjects:\n  - {name: a, shape: {box: [0.2, 0.2, 0.2]}, mass: 1}\n"
      "  - {name: b, shape: {cylinder: [0.1, 0.2]}, mass: 1}\n"
      "  - {name: c, shape: {sphere: 0.1}, mass: 1}\n",
      ".", "o.yaml");
  SceneCollision oc = scene_collision(o, nullptr);
  std::vector<SE3> poses = {SE3(Mat3::Identity(), Vec3(0, 0, 0.099)),
                            SE3(Mat3::Identity(), Vec3(1, 0, 0.099)),
                            SE3(Mat3::Identity(), Vec3(2, 0, 0.099))};
  scene_frame_poses({}, poses, frames);
  collide(oc.model, cd, frames);
  EXPECT_EQ(cd.contacts.size(), 9u);  // 4 + 4 + 1
  EXPECT_EQ(allocations_of([&] {
              for (int k = 0; k < 20; ++k) {
                poses[0].p.x() = 0.001 * k;
                scene_frame_poses({}, poses, frames);
                collide(oc.model, cd, frames);
              }
            }),
            0);
}

// A whole Simulator step (stepper, passive forces, divergence guard with its energy checks,
// last-good copies) allocates nothing, for every registered integrator.
TEST(Alloc, SimulatorSteps) {
  UrdfOptions fixed;
  fixed.locked = {{"panda_finger_joint1", 0.02}, {"panda_finger_joint2", 0.02}};
  UrdfOptions free = fixed;
  free.floating = true;
  for (const UrdfOptions& opt : {fixed, free}) {
    const Model m = model_from_urdf_file(se3_test::robot_path("panda.urdf"), opt);
    for (const std::string& integ : stepper_names()) {
      SCOPED_TRACE(std::string(integ) + (opt.floating ? " free" : " fixed"));
      SimConfig cfg;
      cfg.integrator = integ;
      State x0(m);
      x0.q.setConstant(0.3);
      x0.v.setConstant(0.2);
      Simulator sim(m, x0, cfg);
      sim.set_joint_effort(1, 2.0);
      // The first step too: what a stepper needs (the variational one's mass matrices) is
      // reserved when it is made.
      EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim.step_n(1), 1) << sim.failure(); }), 0);
      EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim.step_n(100), 100) << sim.failure(); }), 0);
    }
  }
}

// A long chain simulated with ABA needs O(n) memory: Data sizes the nv x nv mass-matrix
// workspaces only for crba and minv (issue 17: chain:20000 took 12.6 GB). A 3000-link chain's
// simulator (stepper workspace, diagnostics, states) takes a few MB; one nv x nv matrix alone
// would be 72 MB.
TEST(Alloc, LongChainSimulatorNeedsLinearMemory) {
  const Model m = make_chain(3000, true);
  State x0(m);
  x0.v.setConstant(0.01);
  for (const char* integ : {"semi_implicit_euler", "rkmk4"}) {
    SimConfig cfg;
    cfg.integrator = integ;
    const long bytes = bytes_of([&] {
      Simulator sim(m, x0, cfg);
      EXPECT_EQ(sim.step_n(2), 2) << sim.failure();
    });
    EXPECT_LT(bytes, 30L << 20) << integ;
    std::printf("  %s, free 3000-link chain: simulator and 2 steps requested %.1f MB\n", integ,
                bytes / 1048576.0);
  }
}

// With controllers (position PID and effort), expiring torque commands and link wrenches, on a
// free base with ground contact too: a step still allocates nothing.
TEST(Alloc, SimulatorStepsWithControllersCommandsAndWrenches) {
  const std::string scenes = se3_sim_test::source_dir() + "/config/scenes/";
  for (const char* file : {"fixed_panda.yaml", "quadruped_ground.yaml"}) {
    SCOPED_TRACE(file);
    auto sim = make_simulator(load_scene(scenes + file));
    if (!sim->controllers()) {
      sim->set_controllers(parse_controllers_text(R"(
arm: {type: effort_controllers/JointGroupPositionController, joints: [panda_joint1, panda_joint2],
      pid: {p: 100, i: 10, d: 5, i_clamp: 10}}
wrist: {type: effort_controllers/JointEffortController, joint: panda_joint7}
)"));
    }
    sim->set_command_timeout(0.01);
    sim->set_joint_effort(1, 0.5);
    sim->apply_link_wrench(2, Vec3(0.01, 0, 0), Vec6::Constant(0.1), 0.05);
    sim->apply_link_wrench(1, Vec3::Zero(), Vec6::Constant(0.1), -1);
    ASSERT_EQ(sim->step_n(3), 3) << sim->failure();
    std::vector<double> c = sim->controllers()->command(0);
    EXPECT_EQ(allocations_of([&] {
                sim->set_joint_effort(1, 0.4);
                c[0] += 0.1;
                EXPECT_TRUE(sim->controllers()->set_command(0, c.data(), c.size()).empty());
                EXPECT_EQ(sim->step_n(100), 100) << sim->failure();
              }),
              0);
    EXPECT_EQ(sim->link_wrench_count(), 1);  // the timed one ran out inside, without allocating
  }
}

// A spawn or delete (world.h) swaps its parts in between steps: the steps after the first one
// that follows it allocate nothing (the first may size the constraint workspace once).
TEST(Alloc, StepsAfterASpawnOrDeleteAllocateNothing) {
  auto sim = make_simulator(
      load_scene(se3_sim_test::source_dir() + "/config/scenes/quadruped_ground.yaml"));
  ASSERT_EQ(sim->step_n(3), 3) << sim->failure();
  sim->spawn_object(parse_scene_object(
      "name: ball\nshape: {sphere: 0.05}\nmass: 0.5\npose: {position: [5, 5, 50]}\n", "."));
  const long first = allocations_of([&] { ASSERT_EQ(sim->step_n(1), 1) << sim->failure(); });
  RecordProperty("first_step_allocations_after_spawn", static_cast<int>(first));
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(100), 100) << sim->failure(); }), 0);
  EXPECT_LT(sim->model_state("ball").pose.p.z(), 50);
  sim->delete_model("ball");
  ASSERT_EQ(sim->step_n(1), 1) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(100), 100) << sim->failure(); }), 0);
}

// Several robots (sim.h add_robot): the shipped two_arms scene without its table and box (the
// UR5's mesh contact with them allocates inside FCL whether or not the Panda is there), both
// arms under their trajectory controllers and commands: the steps allocate nothing.
TEST(Alloc, SeveralRobotsStepsAllocateNothing) {
  Scene scene = load_scene(se3_sim_test::source_dir() + "/config/scenes/two_arms.yaml");
  scene.objects.clear();
  auto sim = make_simulator(scene);
  ASSERT_EQ(sim->robot_count(), 2);
  sim->set_robot_joint_effort(1, 2, 5.0);
  sim->set_robot_joint_effort(0, 1, 5.0);
  ASSERT_EQ(sim->step_n(3), 3) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(200), 200) << sim->failure(); }), 0);
  // A link wrench on robot 1 (its forces: a buffer of its own, sized once).
  const int hand = sim->robot_model(1).link_index("panda_hand");
  ASSERT_GE(hand, 0);
  sim->apply_robot_link_wrench(1, hand, Vec3::Zero(), Vec6::Constant(0.5), 0.1);
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(200), 200) << sim->failure(); }), 0);
  EXPECT_EQ(sim->link_wrench_count(), 0);
}

// A robot spawned from its URDF at run time (world.h RobotSpawn) and deleted again: the steps
// after the first one that follows each allocate nothing.
TEST(Alloc, StepsAfterARobotSpawnOrDeleteAllocateNothing) {
  auto sim =
      make_simulator(load_scene(se3_sim_test::source_dir() + "/config/scenes/fixed_arm.yaml"));
  ASSERT_EQ(sim->step_n(3), 3) << sim->failure();
  RobotSpawn panda;
  std::string why;
  ASSERT_TRUE(read_file(se3_test::robot_path("panda.urdf"), panda.urdf, &why)) << why;
  panda.pose.p = Vec3(1, 0, 0);
  panda.base = RobotSpawn::Base::Fixed;
  sim->spawn_robot(panda);
  ASSERT_EQ(sim->step_n(1), 1) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(100), 100) << sim->failure(); }), 0);
  sim->delete_model("panda");
  ASSERT_EQ(sim->step_n(1), 1) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(100), 100) << sim->failure(); }), 0);
}

// Robots spawned into a scene with collision (their shapes in the scene collision, their
// velocities in robot 0's contact step) and one deleted again: the steps after the first that
// follows each allocate nothing while they rest on the ground. (A robot's box resting on the
// block allocates inside FCL's box-box test whether the robot was spawned or listed in the
// scene, as the UR5's meshes do above.)
TEST(Alloc, StepsAfterARobotSpawnOrDeleteInASceneWithCollisionAllocateNothing) {
  const std::string root = se3_sim_test::source_dir();
  auto sim = make_simulator(parse_scene(
      "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\nground: true\n"
      "objects: [{name: block, shape: {box: [0.6, 0.6, 0.2]}, pose: {position: [2, 0, 0.1]}}]\n"
      "robots:\n"
      "  - {name: a, urdf: data/robots/double_pendulum_simple.urdf, base: free,"
      " base_pose: {position: [0, 0, 0.2]}}\n",
      root, "pendulums.yaml"));
  RobotSpawn p;
  std::string why;
  ASSERT_TRUE(read_file(se3_test::robot_path("double_pendulum_simple.urdf"), p.urdf, &why)) << why;
  p.base = RobotSpawn::Base::Free;
  for (const char* name : {"b", "c"}) {
    p.name = name;
    p.pose.p = Vec3(name[0] == 'b' ? 1 : -1, 0, 0.2);
    sim->spawn_robot(p);
  }
  ASSERT_EQ(sim->step_n(300), 300) << sim->failure();  // landed: contacts on every robot
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(200), 200) << sim->failure(); }), 0);
  sim->delete_model("b");
  ASSERT_EQ(sim->step_n(1), 1) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(200), 200) << sim->failure(); }), 0);
}

// A trajectory controller (quintic segments, the effort flavour) on the UR5 and a velocity
// controller through the velocity interface: sampling the splines, the PIDs and the tolerance
// checks allocate nothing in a step.
TEST(Alloc, TrajectoryControllerStepsAllocateNothing) {
  auto sim =
      make_simulator(load_scene(se3_sim_test::source_dir() + "/config/scenes/fixed_arm.yaml"));
  auto specs = parse_controllers_text(R"(
arm:
  type: effort_controllers/JointTrajectoryController
  joints: [shoulder_pan_joint, shoulder_lift_joint, elbow_joint, wrist_1_joint, wrist_2_joint]
  gains:
    shoulder_pan_joint: {p: 4000, d: 200}
    shoulder_lift_joint: {p: 4000, d: 200}
    elbow_joint: {p: 4000, d: 100}
    wrist_1_joint: {p: 300, d: 4}
    wrist_2_joint: {p: 300, d: 4}
  constraints: {goal_time: 1, wrist_1_joint: {trajectory: 1, goal: 0.1}}
wrist: {type: velocity_controllers/JointVelocityController, joint: wrist_3_joint,
        pid: {p: 1}}
)");
  sim->set_controllers(specs);
  TrajectoryCommand cmd;
  cmd.joint_names = specs[0].joints;
  for (int p = 1; p <= 5; ++p) {
    TrajectoryCommand::Point pt;
    pt.time_from_start = 0.05 * p;
    for (int j = 0; j < 5; ++j) {
      pt.positions.push_back(sim->state().q[j] + 0.01 * p);
      pt.velocities.push_back(0.1);
      pt.accelerations.push_back(0.0);
    }
    cmd.points.push_back(pt);
  }
  ASSERT_EQ(sim->controllers()->set_trajectory(0, cmd, sim->time()), "");
  const double w = 0.2;
  ASSERT_EQ(sim->controllers()->set_command(1, &w, 1), "");
  ASSERT_EQ(sim->step_n(3), 3) << sim->failure();
  EXPECT_EQ(allocations_of([&] { EXPECT_EQ(sim->step_n(400), 400) << sim->failure(); }), 0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// Constraint and contact steps (constraints.h through integrate.h's constrained_step) allocate
// nothing after the first, counting malloc as well as operator new: the four-bar loop (rkmk4
// with eq. (32) in every stage, projection), the pinned chain, Solo12 on the ground (the
// velocity level, PGS and the active-set solver), and free objects on the ground in a
// Simulator (rows from outside contacts, free bodies). Collision detection is not in these
// steps (the ground contacts are the sim layer's own).
TEST(Alloc, ConstraintAndContactStepsAllocateNothingAfterTheFirst) {
  const std::string scenes = se3_sim_test::source_dir() + "/config/scenes/";
  for (const char* name : {"fourbar", "pinned_chain", "quadruped_ground"}) {
    for (ContactSolver solver : {ContactSolver::PGS, ContactSolver::ActiveSet}) {
      SCOPED_TRACE(std::string(name) + (solver == ContactSolver::PGS ? " pgs" : " active_set"));
      Scene sc = load_scene(scenes + name + ".yaml");
      sc.constraints.options.solver = solver;
      const Model m = scene_model(sc);
      ConstraintSystem cs(m, scene_constraints(sc, m));
      State x = scene_state(sc, m);
      cs.anchor(x);
      auto stepper = make_stepper(sc.integrator, m);
      const VecX tau = VecX::Zero(m.nv);
      for (int k = 0; k < 10; ++k) ASSERT_TRUE(constrained_step(cs, *stepper, x, tau, sc.dt).ok);
      EXPECT_EQ(allocations_of([&] {
                  for (int k = 0; k < 300; ++k) constrained_step(cs, *stepper, x, tau, sc.dt);
                }),
                0);
    }
  }
  // Free bodies with contacts from outside (the collision layer's list; collide() itself, FCL's,
  // is not counted here): a robot on the ground plus two boxes, one resting on the ground at its
  // four corners, one on it.
  const Scene sc = load_scene(scenes + "quadruped_ground.yaml");
  const Model m = scene_model(sc);
  ConstraintSystem cs(m, scene_constraints(sc, m));
  std::vector<Model> boxes(2);
  std::vector<const Model*> models;
  for (Model& b : boxes) {
    b.floating = true;
    b.start_with_base("box", Inertia::from_com(1, Vec3::Zero(), 0.01 * Mat3::Identity()));
    b.finalize();
    models.push_back(&b);
  }
  cs.set_free_bodies(models, 16);
  std::vector<State> states = {State(boxes[0]), State(boxes[1])};
  states[0].base.p = Vec3(2, 0, 0.1);
  states[1].base.p = Vec3(2, 0, 0.3);
  std::vector<VecX> a_free(2, VecX::Zero(6));
  for (VecX& a : a_free) a[5] = -9.81;
  std::vector<CollisionObject> objects(3);
  objects[0].frame = m.n + 1;
  objects[1].frame = m.n + 2;
  objects[2].frame = CollisionObject::kWorld;  // the ground
  std::vector<Contact> contacts;
  for (int k = 0; k < 8; ++k) {
    Contact c;
    c.a = k < 4 ? 2 : 0;
    c.b = k < 4 ? 0 : 1;
    c.point = Vec3(2 + ((k & 1) ? 0.1 : -0.1), (k & 2) ? 0.1 : -0.1, k < 4 ? 0.0 : 0.2);
    contacts.push_back(c);
  }
  EXPECT_EQ(
      steps_with_bodies_allocations(cs, sc, m, {&models, &states, &a_free, &contacts, &objects}),
      0);
  EXPECT_LT(states[1].v.norm(), 1e-3);  // the contacts held the boxes
}

// W's columns formed on demand (the active set with most rows unloaded: a box resting on four
// corners among 16 contacts 5 mm apart; the robot flies, without its ground contacts) take
// nothing from the heap either: the "column formed" flags and W's diagonal are sized with the
// rest of the constraint system.
TEST(Alloc, LazyDelassusColumnsAllocateNothing) {
  const std::string scenes = se3_sim_test::source_dir() + "/config/scenes/";
  Scene sc = load_scene(scenes + "quadruped_ground.yaml");
  sc.constraints.options.solver = ContactSolver::ActiveSet;
  const Model m = scene_model(sc);
  ConstraintSpec spec = scene_constraints(sc, m);
  spec.ground = false;  // the robot flies: the box's contacts alone
  ConstraintSystem cs(m, spec);
  Model box;
  box.floating = true;
  box.start_with_base("box", Inertia::from_com(1, Vec3::Zero(), 0.01 * Mat3::Identity()));
  box.finalize();
  std::vector<const Model*> models = {&box};
  cs.set_free_bodies(models, 20);
  std::vector<State> states = {State(box)};
  states[0].base.p = Vec3(2, 0, 0.1);
  std::vector<VecX> a_free(1, VecX::Zero(6));
  a_free[0][5] = -9.81;
  std::vector<CollisionObject> objects(2);
  objects[0].frame = m.n + 1;
  objects[1].frame = CollisionObject::kWorld;  // the ground
  std::vector<Contact> contacts;
  for (int k = 0; k < 20; ++k) {  // four corners touching, then 16 points 5 mm apart
    Contact c;
    c.a = 1;
    c.b = 0;
    c.point = k < 4 ? Vec3(2 + ((k & 1) ? 0.1 : -0.1), (k & 2) ? 0.1 : -0.1, 0)
                    : Vec3(2 + 0.1 * std::cos(0.4 * k), 0.1 * std::sin(0.4 * k), 0);
    c.depth = k < 4 ? 0.0 : -0.005;
    contacts.push_back(c);
  }
  EXPECT_EQ(
      steps_with_bodies_allocations(cs, sc, m, {&models, &states, &a_free, &contacts, &objects}),
      0);
  EXPECT_LT(cs.report().delassus_columns, cs.report().rows / 2);  // the lazy path was taken
  EXPECT_LT(states[0].v.norm(), 1e-3);                            // the corners held the box
}
