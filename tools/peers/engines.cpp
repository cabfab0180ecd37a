// Engines (engines.h): ours through the stepper registry, MuJoCo's and DART's integrators.
#include "engines.h"

#include <stdexcept>

#include "se3_sim/integrate/integrate.h"

#ifdef SE3_SIM_HAVE_MUJOCO
#include "mujoco_peer.h"
#endif
#ifdef SE3_SIM_HAVE_DART
#include "dart_peer.h"
#endif

namespace se3::peers {
namespace {

class OursEngine : public Engine {
 public:
  OursEngine(const std::string& name, const Model& m, bool passive, double tol)
      : zero_(VecX::Zero(m.nv)) {
    StepperOptions o;
    o.passive_forces = passive;
    o.tol = tol;
    o.max_substeps = 10000000;
    stepper_ = make_stepper(name, m, o);
    x_ = State(m);
  }
  void set_state(const State& x) override {
    x_.base = x.base;
    x_.q = x.q;
    x_.v = x.v;
    stepper_->restart();
  }
  bool step(double h) override {
    const StepInfo info = stepper_->step(x_, zero_, h);
    evals_ = info.evaluations;
    return info.ok && x_.finite() && x_.v.cwiseAbs().maxCoeff() < 1e8;
  }
  void get_state(State& x) override {
    x.base = x_.base;
    x.q = x_.q;
    x.v = x_.v;
  }
  int evaluations() const override { return evals_; }

 private:
  std::unique_ptr<Stepper> stepper_;
  State x_;
  VecX zero_;
  int evals_ = 0;
};

#ifdef SE3_SIM_HAVE_MUJOCO
class MujocoEngine : public Engine {
 public:
  MujocoEngine(int integrator, const Model& m, bool passive, bool limits) {
    MujocoOptions o;
    o.keep_damping = passive;
    o.limits = limits;
    robot_ = mujoco_from_model(m, o);
    robot_->m()->opt.integrator = integrator;
    evals_ = integrator == mjINT_RK4 ? 4 : 1;
  }
  void set_state(const State& x) override {
    mj_resetData(robot_->m(), robot_->d());
    robot_->set_state(x);
  }
  bool step(double h) override {
    mjModel* m = robot_->m();
    mjData* d = robot_->d();
    m->opt.timestep = h;
    const int bad = d->warning[mjWARN_BADQACC].number;
    mj_step(m, d);
    return d->warning[mjWARN_BADQACC].number == bad;
  }
  void get_state(State& x) override { robot_->get_state(x); }
  int evaluations() const override { return evals_; }

 private:
  std::unique_ptr<MujocoRobot> robot_;
  int evals_ = 1;
};
#endif

#ifdef SE3_SIM_HAVE_DART
class DartEngine : public Engine {
 public:
  DartEngine(const Model& m, bool passive) : robot_(m, passive) {}
  void set_state(const State& x) override { robot_.set_state(x); }
  bool step(double h) override { return robot_.step(h); }
  void get_state(State& x) override { robot_.get_state(x); }
  int evaluations() const override { return 1; }

 private:
  DartRobot robot_;
};
#endif

}  // namespace

std::unique_ptr<Engine> make_engine(const std::string& name, const Model& model, bool passive,
                                    double tol, bool limits) {
#ifdef SE3_SIM_HAVE_MUJOCO
  if (name == "mujoco_euler") {
    return std::make_unique<MujocoEngine>(mjINT_EULER, model, passive, limits);
  }
  if (name == "mujoco_rk4")
    return std::make_unique<MujocoEngine>(mjINT_RK4, model, passive, limits);
  if (name == "mujoco_implicit") {
    return std::make_unique<MujocoEngine>(mjINT_IMPLICIT, model, passive, limits);
  }
#endif
  if (limits) {
    throw std::invalid_argument("engine '" + name + "' is not run with joint limits here");
  }
#ifdef SE3_SIM_HAVE_DART
  if (name == "dart_euler") return std::make_unique<DartEngine>(model, passive);
#endif
  if (name.rfind("mujoco_", 0) == 0 || name.rfind("dart_", 0) == 0) {
    throw std::invalid_argument("engine '" + name + "' is not in this build");
  }
  return std::make_unique<OursEngine>(name, model, passive, tol);
}

std::vector<std::string> peer_engine_names() {
  std::vector<std::string> out;
#ifdef SE3_SIM_HAVE_MUJOCO
  out.insert(out.end(), {"mujoco_euler", "mujoco_rk4", "mujoco_implicit"});
#endif
#ifdef SE3_SIM_HAVE_DART
  out.push_back("dart_euler");
#endif
  return out;
}

std::string engine_label(const std::string& name) {
  if (name == "mujoco_euler") return "MuJoCo Euler";
  if (name == "mujoco_rk4") return "MuJoCo RK4";
  if (name == "mujoco_implicit") return "MuJoCo implicit";
  if (name == "dart_euler") return "DART semi-implicit Euler";
  return name;
}

}  // namespace se3::peers
