// Contact steps per shipped scene against MuJoCo 2.2's mj_step on the same scene, in the same
// run: time per step (median of 3 runs of 2 s simulated), deepest penetration over the run, and
// drift (the largest displacement of a free object from where it started: a stack or a resting
// object should not move). MuJoCo gets the scene's objects as MJCF (boxes, spheres, capsules,
// cylinders; free joints; static geoms; the ground as a plane), the same dt, gravity and mu, its
// default Newton solver with elliptic cones. Robot scenes are timed on our side only here (the
// URDF through MuJoCo's compiler with matching collision geometry is not done yet).
//   devel/lib/se3_sim/bench_contact [scene.yaml ...]   (default: the shipped contact scenes)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "se3_sim/sim.h"

#ifdef SE3_SIM_HAVE_MUJOCO
#include <mujoco/mujoco.h>
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

// The objects of a robot-free scene as MJCF; "" when MuJoCo cannot take it here.
std::string mjcf(const Scene& sc) {
  if (!sc.robot_path.empty()) return "";
  std::ostringstream x;
  x << "<mujoco><option timestep=\"" << sc.dt << "\" gravity=\"" << sc.gravity.x() << " "
    << sc.gravity.y() << " " << sc.gravity.z() << "\" cone=\"elliptic\"/><worldbody>";
  if (sc.constraints.ground) {
    x << "<geom type=\"plane\" size=\"0 0 1\" friction=\"" << sc.constraints.mu
      << " 0.005 0.0001\"/>";
  }
  for (const SceneObject& o : sc.objects) {
    const std::string g = geom(o);
    if (g.empty()) return "";
    const Eigen::Vector4d q = quaternion_from_rotation(o.pose.R);  // x y z w
    std::ostringstream pose;
    pose << "pos=\"" << o.pose.p.x() << " " << o.pose.p.y() << " " << o.pose.p.z() << "\" quat=\""
         << q[3] << " " << q[0] << " " << q[1] << " " << q[2] << "\"";
    if (o.is_static) {
      x << "<geom " << g << " " << pose.str() << "/>";
    } else {
      const Mat3& I = o.inertia.I;
      x << "<body " << pose.str() << "><freejoint/><inertial pos=\"0 0 0\" mass=\"" << o.mass
        << "\" fullinertia=\"" << I(0, 0) << " " << I(1, 1) << " " << I(2, 2) << " " << I(0, 1)
        << " " << I(0, 2) << " " << I(1, 2) << "\"/><geom " << g << "/></body>";
    }
  }
  x << "</worldbody></mujoco>";
  return x.str();
}

Figures theirs(const std::string& file) {
  Figures f;
  const Scene sc = load_scene(file);
  const std::string xml = mjcf(sc);
  if (xml.empty()) return f;
  char err[1000] = "";
  auto vfs = std::make_unique<mjVFS>();  // 2 MB of file names: not on the stack
  mj_defaultVFS(vfs.get());
  mj_makeEmptyFileVFS(vfs.get(), "scene.xml", static_cast<int>(xml.size()));
  std::copy(xml.begin(), xml.end(), static_cast<char*>(vfs->filedata[vfs->nfile - 1]));
  mjModel* m = mj_loadXML("scene.xml", vfs.get(), err, sizeof err);
  mj_deleteVFS(vfs.get());
  if (!m) {
    std::fprintf(stderr, "%s: MuJoCo: %s\n", file.c_str(), err);
    return f;
  }
  std::vector<double> t;
  for (int rep = 0; rep < 3; ++rep) {
    mjData* d = mj_makeData(m);
    const int n = static_cast<int>(2.0 / m->opt.timestep);
    double pen = 0, tsum = 0;
    for (int k = 0; k < n; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      mj_step(m, d);
      tsum += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (int c = 0; c < d->ncon; ++c) pen = std::max(pen, -d->contact[c].dist);
    }
    t.push_back(tsum / n * 1e6);
    f.penetration = pen;
    double drift = 0;
    for (int b = 1; b < m->nbody; ++b) {
      const mjtNum* p0 = m->body_pos + 3 * b;
      const mjtNum* p = d->xpos + 3 * b;
      drift = std::max(drift,
                       std::sqrt((p[0] - p0[0]) * (p[0] - p0[0]) + (p[1] - p0[1]) * (p[1] - p0[1]) +
                                 (p[2] - p0[2]) * (p[2] - p0[2])));
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

int main(int argc, char** argv) {
  const std::string dir = std::string(SE3_SIM_SOURCE_DIR) + "/config/scenes/";
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
