// Contact steps per shipped scene against MuJoCo 2.2's mj_step on the same scene, in the same
// run: time per step (median of 3 runs of 2 s simulated), deepest penetration over the run, and
// drift (the largest displacement of a free object from where it started: a stack or a resting
// object should not move). MuJoCo gets the scene's objects as MJCF (boxes, spheres, capsules,
// cylinders; free joints; static geoms; the ground as a plane), the same dt, gravity and mu, its
// default Newton solver with elliptic cones. A robot scene's robot goes through MuJoCo's URDF
// compiler: the URDF of our model (model_to_urdf: body frames, locked joints fused, a floating
// joint from a dummy root for a free base) with the collision shapes of the scene's robot
// (meshes by their resolved path; MuJoCo collides with their convex hulls, as we do), saved by
// MuJoCo as MJCF, and the objects and the ground added to that MJCF. Robot-robot pairs collide
// only with `self_collision: true` (then the SRDF's disabled pairs are excluded; MuJoCo skips
// parent-child pairs as we skip adjacent links); the robot's shapes get the ground's mu; the
// scene's position controllers run on MuJoCo's side as the same PIDs (se3::Pid) on
// qfrc_applied, outside the timed mj_step.
//   devel/lib/se3_sim/bench_contact [scene.yaml ...]   (default: the shipped contact scenes)
//   devel/lib/se3_sim/bench_contact --study OUT.csv    (the contact part of the speed-accuracy
//                                                       study; scripts/charts.sh charts it)
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"

#ifdef SE3_SIM_HAVE_MUJOCO
#include <mujoco/mujoco.h>

#include "../test/source_paths.h"
#endif

using namespace se3;

namespace {

struct Figures {
  double us_per_step = NAN, penetration = NAN, drift = NAN;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Figures ours(const std::string& file) {
  Figures f;
  std::vector<double> t;
  for (int rep = 0; rep < 3; ++rep) {
    auto sim = make_simulator(load_scene(file));
    const int n = static_cast<int>(2.0 / sim->dt());
    std::vector<Vec3> start;
    for (const ObjectState& o : sim->objects()) start.push_back(o.pose.p);
    const auto t0 = std::chrono::steady_clock::now();
    sim->step_n(n);
    const auto t1 = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double>(t1 - t0).count() / n * 1e6);
    f.penetration = sim->penetration_max();
    double drift = 0;
    for (size_t j = 0; j < start.size(); ++j) {
      if (!sim->objects()[j].is_static) {
        drift = std::max(drift, (sim->objects()[j].pose.p - start[j]).norm());
      }
    }
    f.drift = drift;
  }
  f.us_per_step = median(t);
  return f;
}

#ifdef SE3_SIM_HAVE_MUJOCO
std::string geom(const SceneObject& o) {
  std::ostringstream g;
  const Shape& s = o.shape;
  switch (s.type) {
    case ShapeType::Box:
      g << "type=\"box\" size=\"" << s.box.x() / 2 << " " << s.box.y() / 2 << " " << s.box.z() / 2
        << "\"";
      break;
    case ShapeType::Sphere:
      g << "type=\"sphere\" size=\"" << s.radius << "\"";
      break;
    case ShapeType::Capsule:
      g << "type=\"capsule\" size=\"" << s.radius << " " << s.length / 2 << "\"";
      break;
    case ShapeType::Cylinder:
      g << "type=\"cylinder\" size=\"" << s.radius << " " << s.length / 2 << "\"";
      break;
    case ShapeType::Mesh:
      return "";
  }
  g << " friction=\"" << o.mu << " 0.005 0.0001\"";
  return g.str();
}

// The scene's objects (and the ground) as MJCF worldbody elements; "" when one cannot be given.
// Free objects are bodies named obj<j>.
std::string objects_mjcf(const Scene& sc) {
  std::ostringstream x;
  if (sc.constraints.ground) {
    x << "<geom name=\"se3obj_ground\" type=\"plane\" size=\"0 0 1\" friction=\""
      << sc.constraints.mu << " 0.005 0.0001\"/>";
  }
  int j = 0, k = 0;
  for (const SceneObject& o : sc.objects) {
    if (geom(o).empty()) return "";
    const std::string g = "name=\"se3obj" + std::to_string(k++) + "\" " + geom(o);
    const Eigen::Vector4d q = quaternion_from_rotation(o.pose.R);  // x y z w
    std::ostringstream pose;
    pose << "pos=\"" << o.pose.p.x() << " " << o.pose.p.y() << " " << o.pose.p.z() << "\" quat=\""
         << q[3] << " " << q[0] << " " << q[1] << " " << q[2] << "\"";
    if (o.is_static) {
      x << "<geom " << g << " " << pose.str() << "/>";
    } else {
      const Mat3& I = o.inertia.I;
      x << "<body name=\"obj" << j++ << "\" " << pose.str()
        << "><freejoint/><inertial pos=\"0 0 0\" mass=\"" << o.mass << "\" fullinertia=\""
        << I(0, 0) << " " << I(1, 1) << " " << I(2, 2) << " " << I(0, 1) << " " << I(0, 2) << " "
        << I(1, 2) << "\"/><geom " << g << "/></body>";
    }
  }
  return x.str();
}

// MuJoCo model of a robot-free scene.
mjModel* load_objects(const Scene& sc, char* err, int nerr) {
  const std::string objs = objects_mjcf(sc);
  if (objs.empty() && !sc.objects.empty()) return nullptr;
  const std::string xml = "<mujoco><worldbody>" + objs + "</worldbody></mujoco>";
  auto vfs = std::make_unique<mjVFS>();  // 2 MB of file names: not on the stack
  mj_defaultVFS(vfs.get());
  mj_makeEmptyFileVFS(vfs.get(), "scene.xml", static_cast<int>(xml.size()));
  std::copy(xml.begin(), xml.end(), static_cast<char*>(vfs->filedata[vfs->nfile - 1]));
  mjModel* m = mj_loadXML("scene.xml", vfs.get(), err, nerr);
  mj_deleteVFS(vfs.get());
  return m;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The robot of a scene in MuJoCo (see the file comment), with the objects added to its MJCF.
// Object geoms are named se3obj...; the others are the robot's.
mjModel* load_robot(const Scene& sc, const Model& model, char* err, int nerr) {
  GeometryModel g;
  const bool spheres = !sc.constraints.contacts.empty() &&
                       !sc.constraints.contacts_from_collisions && sc.objects.empty() &&
                       !sc.self_collision;
  if (spheres) {  // the scene's `contacts:` spheres on their links (a point: radius 0.1 mm)
    for (const ContactPoint& c : sc.constraints.contacts) {
      const int l = model.link_index(c.link);
      if (l < 0) return nullptr;
      GeometryObject geo;
      geo.body = model.links[l].body;
      geo.placement = SE3(Mat3::Identity(), model.links[l].offset.act(c.position));
      geo.shape = make_sphere(std::max(c.radius, 1e-4));
      g.visuals.push_back(geo);
    }
  } else {  // the robot's collision shapes, meshes by their resolved file
    GeometryOptions gopt;
    gopt.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
    const GeometryModel loaded = scene_geometry(sc, model, "", gopt);
    for (GeometryObject geo : loaded.collisions) {
      if (geo.stand_in || geo.body < 0) continue;
      if (geo.shape.type == ShapeType::Mesh) geo.shape.resource = geo.shape.path;
      g.visuals.push_back(geo);
    }
  }
  std::string urdf = model_to_urdf(model, &g);
  for (const char* tag : {"visual>"}) {
    for (std::size_t k; (k = urdf.find(tag)) != std::string::npos;) {
      urdf.replace(k, 6, "collision");
    }
  }
  if (model.floating) {
    urdf.insert(urdf.rfind("</robot>"),
                "<link name=\"se3_sim_world\"/><joint name=\"se3_sim_free\" "
                "type=\"floating\"><parent link=\"se3_sim_world\"/><child "
                "link=\"" +
                    model.body_name[0] + "\"/></joint>\n");
  }
  urdf.insert(urdf.find('>', urdf.find("<robot")) + 1,
              "<mujoco><compiler fusestatic=\"true\" inertiafromgeom=\"false\" boundmass=\"0\" "
              "boundinertia=\"0\" balanceinertia=\"true\" strippath=\"false\" "
              "discardvisual=\"false\"/></mujoco>");
  const std::string base = "/tmp/se3_sim_bench_contact_" + std::to_string(getpid());
  std::ofstream(base + ".urdf") << urdf;
  mjModel* r = mj_loadXML((base + ".urdf").c_str(), nullptr, err, nerr);
  std::remove((base + ".urdf").c_str());
  if (!r) return nullptr;
  const bool saved = mj_saveLastXML((base + ".xml").c_str(), r, err, nerr);
  mj_deleteModel(r);
  if (!saved) return nullptr;
  std::string xml = slurp(base + ".xml");
  const std::string objs = objects_mjcf(sc);
  if (objs.empty() && !sc.objects.empty()) return nullptr;
  xml.insert(xml.rfind("</worldbody>"), objs);
  if (sc.self_collision && !sc.srdf.empty()) {
    std::ostringstream ex;
    ex << "<contact>";
    for (const auto& pr : srdf_disabled_pairs(slurp(sc.srdf))) {
      const int a = model.link_index(pr.first), b = model.link_index(pr.second);
      if (a < 0 || b < 0 || model.links[a].body == model.links[b].body) continue;
      const int ba = model.links[a].body, bb = model.links[b].body;
      if ((ba == 0 || bb == 0) && !model.floating) continue;  // the world body
      ex << "<exclude body1=\"" << model.body_name[ba] << "\" body2=\"" << model.body_name[bb]
         << "\"/>";
    }
    // MuJoCo's parent-child filter skips a body welded to the world: its children by hand.
    for (int i = 1; i <= model.n && !model.floating; ++i) {
      if (model.parent[i] == 0)
        ex << "<exclude body1=\"world\" body2=\"" << model.body_name[i] << "\"/>";
    }
    ex << "</contact>";
    xml.insert(xml.rfind("</mujoco>"), ex.str());
  }
  std::ofstream(base + ".xml") << xml;
  mjModel* m = mj_loadXML((base + ".xml").c_str(), nullptr, err, nerr);
  if (!std::getenv("BENCH_CONTACT_KEEP_MJCF")) std::remove((base + ".xml").c_str());
  if (!m) return nullptr;
  for (int k = 0; k < m->ngeom; ++k) {
    const char* nm = mj_id2name(m, mjOBJ_GEOM, k);
    if (nm && std::string(nm).rfind("se3obj", 0) == 0) {
      m->geom_contype[k] = m->geom_conaffinity[k] = 3;
      continue;
    }
    m->geom_friction[3 * k] = sc.constraints.mu;  // the robot's shapes: the ground's mu
    if (!sc.self_collision) {  // robot-robot never: type 1 meets affinity 2 (objects: 3, 3)
      m->geom_contype[k] = 1;
      m->geom_conaffinity[k] = 2;
    }
  }
  return m;
}

Figures theirs(const std::string& file) {
  Figures f;
  const Scene sc = load_scene(file);
  char err[1000] = "";
  std::unique_ptr<Model> model;
  mjModel* m = nullptr;
  if (sc.robot_path.empty()) {
    m = load_objects(sc, err, sizeof err);
  } else {
    model = std::make_unique<Model>(scene_model(sc));
    m = load_robot(sc, *model, err, sizeof err);
  }
  if (!m) {
    if (err[0]) std::fprintf(stderr, "%s: MuJoCo: %s\n", file.c_str(), err);
    return f;
  }
  m->opt.timestep = sc.dt;
  for (int k = 0; k < 3; ++k) m->opt.gravity[k] = sc.gravity[k];
  m->opt.cone = mjCONE_ELLIPTIC;
  // The robot's initial state and its controllers' joints (MuJoCo qpos / dof by joint name).
  State x0;
  struct Servo {
    int qpos, dof;
    double target, limit;  // the command, the URDF effort limit (ours clamps to it too)
    Pid pid;
  };
  std::vector<Servo> servos;
  std::vector<std::pair<int, int>> joints;  // (qpos, dof) of our joint i, 1..n
  if (model) {
    x0 = scene_state(sc, *model);
    joints.resize(model->n + 1);
    for (int i = 1; i <= model->n; ++i) {
      const int j = mj_name2id(m, mjOBJ_JOINT, model->joint_name[i].c_str());
      if (j < 0) {
        std::fprintf(stderr, "%s: MuJoCo has no joint %s\n", file.c_str(),
                     model->joint_name[i].c_str());
        mj_deleteModel(m);
        return f;
      }
      joints[i] = {m->jnt_qposadr[j], m->jnt_dofadr[j]};
    }
    for (const ControllerSpec& c : sc.controllers) {
      for (std::size_t k = 0; k < c.joints.size() && k < c.gains.size(); ++k) {
        const int i = model->joint_index(c.joints[k]);
        if (i < 1) continue;
        servos.push_back({joints[i].first, joints[i].second, x0.q[model->idx_q(i)],
                          model->effort[i], Pid(c.gains[k])});
      }
    }
  }
  std::vector<int> objects;  // MuJoCo body ids of the free objects
  for (int b = 1; b < m->nbody; ++b) {
    const char* nm = mj_id2name(m, mjOBJ_BODY, b);
    if (nm && std::string(nm).rfind("obj", 0) == 0) objects.push_back(b);
  }
  std::vector<double> t;
  for (int rep = 0; rep < 3; ++rep) {
    mjData* d = mj_makeData(m);
    if (model) {
      for (int i = 1; i <= model->n; ++i) {
        d->qpos[joints[i].first] = x0.q[model->idx_q(i)];
        d->qvel[joints[i].second] = x0.v[model->idx_v(i)];
      }
      if (model->floating) {
        const int j = mj_name2id(m, mjOBJ_JOINT, "se3_sim_free");
        mjtNum* q = d->qpos + m->jnt_qposadr[j];
        const Eigen::Vector4d r = quaternion_from_rotation(x0.base.R);
        for (int k = 0; k < 3; ++k) q[k] = x0.base.p[k];
        q[3] = r[3], q[4] = r[0], q[5] = r[1], q[6] = r[2];
      }
      for (Servo& s : servos) s.pid.reset();
    }
    mj_forward(m, d);
    std::vector<Vec3> start;
    for (int b : objects)
      start.push_back(Vec3(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]));
    const int n = static_cast<int>(2.0 / m->opt.timestep);
    double pen = 0, tsum = 0;
    for (int k = 0; k < n; ++k) {
      for (Servo& s : servos) {
        const double u = s.pid.compute(s.target - d->qpos[s.qpos], m->opt.timestep);
        d->qfrc_applied[s.dof] =
            std::isfinite(s.limit) && s.limit > 0 ? std::clamp(u, -s.limit, s.limit) : u;
      }
      const auto t0 = std::chrono::steady_clock::now();
      mj_step(m, d);
      tsum += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (int c = 0; c < d->ncon; ++c) pen = std::max(pen, -d->contact[c].dist);
    }
    t.push_back(tsum / n * 1e6);
    f.penetration = pen;
    double drift = 0;
    for (std::size_t k = 0; k < objects.size(); ++k) {
      const int b = objects[k];
      drift = std::max(
          drift, (Vec3(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]) - start[k]).norm());
    }
    f.drift = drift;
    mj_deleteData(d);
  }
  f.us_per_step = median(t);
  mj_deleteModel(m);
  return f;
}
#else
Figures theirs(const std::string&) {
  return {};
}
#endif

}  // namespace

// ------------------------------------------------------------------ the contact study
// The contact part of the study of Erez, Tassa and Todorov (ICRA 2015; the other models are in
// tools/charts): a pile in motion, the box stack with its top box thrown sideways and spinning
// (v = 2 m/s along x, w = 5 rad/s about z) so that it slides, tips off and lands, simulated for
// 1 s at steps of 4 .. 0.25 ms by each engine. Measured as the paper measures: speed (simulated
// seconds per CPU second of the steps), consistency (the largest distance between a free
// object's final position and the same engine's at a 16x smaller step than the smallest) and the
// deepest penetration over the run. Ours: the scene's contact scheme (contact_semi_implicit,
// active set); MuJoCo 2.2: Euler and RK4 with its default Newton solver, elliptic cones.
namespace {

constexpr double kStudyT = 1.0;

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct StudyRun {
  std::vector<Vec3> final_positions;  // free objects, in scene order
  double cpu = 0, penetration = 0;
  bool ok = true;
};

Scene study_scene(const std::string& file, double dt) {
  Scene sc = load_scene(file);
  sc.dt = dt;
  SceneObject& top = sc.objects.back();
  top.twist << 0, 0, 5, 2, 0, 0;  // body frame [w; v]; the box starts unrotated
  return sc;
}

StudyRun study_ours(const std::string& file, double dt) {
  StudyRun r;
  auto sim = make_simulator(study_scene(file, dt));
  const int n = static_cast<int>(std::lround(kStudyT / dt));
  const double t0 = cpu_seconds();
  for (int k = 0; k < n && r.ok; ++k) r.ok = sim->step();
  r.cpu = cpu_seconds() - t0;
  r.penetration = sim->penetration_max();
  for (const ObjectState& o : sim->objects())
    if (!o.is_static) r.final_positions.push_back(o.pose.p);
  return r;
}

#ifdef SE3_SIM_HAVE_MUJOCO
StudyRun study_mujoco(const std::string& file, double dt, int integrator) {
  StudyRun r;
  const Scene sc = study_scene(file, dt);
  char err[1000] = "";
  mjModel* m = load_objects(sc, err, sizeof err);
  if (!m) {
    r.ok = false;
    return r;
  }
  m->opt.timestep = dt;
  for (int k = 0; k < 3; ++k) m->opt.gravity[k] = sc.gravity[k];
  m->opt.cone = mjCONE_ELLIPTIC;
  m->opt.integrator = integrator;
  mjData* d = mj_makeData(m);
  // MuJoCo's free joint: linear velocity in the world, angular in the body frame; the objects
  // start unrotated, so both are the scene's body-frame twist.
  int j = 0;
  std::vector<int> bodies;
  for (const SceneObject& o : sc.objects) {
    if (o.is_static) continue;
    const int b = mj_name2id(m, mjOBJ_BODY, ("obj" + std::to_string(j++)).c_str());
    bodies.push_back(b);
    mjtNum* qv = d->qvel + m->body_dofadr[b];
    for (int k = 0; k < 3; ++k) qv[k] = o.twist[3 + k], qv[3 + k] = o.twist[k];
  }
  mj_forward(m, d);
  const int n = static_cast<int>(std::lround(kStudyT / dt));
  double pen = 0;
  const double t0 = cpu_seconds();
  double outside = 0;
  for (int k = 0; k < n; ++k) {
    mj_step(m, d);
    const double t1 = cpu_seconds();
    for (int c = 0; c < d->ncon; ++c) pen = std::max(pen, -d->contact[c].dist);
    outside += cpu_seconds() - t1;
  }
  r.cpu = cpu_seconds() - t0 - outside;
  r.penetration = pen;
  for (int b : bodies) {
    const Vec3 p(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]);
    r.ok = r.ok && p.allFinite();
    r.final_positions.push_back(p);
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  return r;
}
#endif

double consistency(const StudyRun& a, const StudyRun& ref) {
  if (!a.ok || !ref.ok || a.final_positions.size() != ref.final_positions.size()) return NAN;
  double e = 0;
  for (std::size_t k = 0; k < a.final_positions.size(); ++k)
    e = std::max(e, (a.final_positions[k] - ref.final_positions[k]).norm());
  return e;
}

// Writes the study's rows (the columns of tools/charts' study.csv, plus penetration) to `out`.
int contact_study(const std::string& file, const std::string& out) {
  std::ofstream f(out);
  if (!f) {
    std::fprintf(stderr, "bench_contact: cannot write %s\n", out.c_str());
    return 1;
  }
  f << "model,engine,dt,rtf,consistency,penetration,ok\n";
  const std::vector<double> dts = {4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4};
  const double dt_ref = dts.back() / 16;
  struct Engine {
    std::string name;
    std::function<StudyRun(double)> run;
  };
  std::vector<Engine> engines = {
      {"contact_semi_implicit", [&](double dt) { return study_ours(file, dt); }}};
#ifdef SE3_SIM_HAVE_MUJOCO
  engines.push_back(
      {"mujoco_euler", [&](double dt) { return study_mujoco(file, dt, mjINT_EULER); }});
  engines.push_back({"mujoco_rk4", [&](double dt) { return study_mujoco(file, dt, mjINT_RK4); }});
#endif
  std::printf("contact study: %s, top box thrown (2 m/s, 5 rad/s), T = %g s, reference dt %g\n",
              file.c_str(), kStudyT, dt_ref);
  for (const Engine& e : engines) {
    const StudyRun ref = e.run(dt_ref);
    for (double dt : dts) {
      const StudyRun r = e.run(dt);
      const double rtf = r.cpu > 0 ? kStudyT / r.cpu : NAN;
      const double c = consistency(r, ref);
      f << "box_pile," << e.name << "," << dt << "," << rtf << "," << c << "," << r.penetration
        << "," << (r.ok ? 1 : 0) << "\n";
      std::printf("  %-22s dt %-7g rtf %8.3g  consistency %9.3g m  deepest %9.3g m%s\n",
                  e.name.c_str(), dt, rtf, c, r.penetration, r.ok ? "" : "  [failed]");
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = se3_sim_test::source_dir() + "/config/scenes/";
  if (argc == 3 && std::string(argv[1]) == "--study") {
    return contact_study(dir + "box_stack.yaml", argv[2]);
  }
  std::vector<std::string> files;
  for (int a = 1; a < argc; ++a) files.push_back(argv[a]);
  if (files.empty()) {
    for (const char* s : {"box_stack", "ball_on_table", "panda_push", "solo12_meshes",
                          "ur5_self_collision", "quadruped_ground"}) {
      files.push_back(dir + s + ".yaml");
    }
  }
  std::printf(
      "| scene | se3_sim us/step | mj_step us/step | se3_sim deepest (m) | MuJoCo deepest "
      "(m) | se3_sim drift (m) | MuJoCo drift (m) |\n|---|---|---|---|---|---|---|\n");
  for (const std::string& f : files) {
    const Figures a = ours(f), b = theirs(f);
    std::string name = f.substr(f.find_last_of('/') + 1);
    std::printf("| %s | %.1f | %.1f | %.2g | %.2g | %.2g | %.2g |\n", name.c_str(), a.us_per_step,
                b.us_per_step, a.penetration, b.penetration, a.drift, b.drift);
  }
  return 0;
}
