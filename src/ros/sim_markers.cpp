// The simulator node's markers (sim_markers.h).
#include "se3_sim/ros/sim_markers.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "se3_sim/ros/convert.h"

namespace se3_ros {

namespace {

geometry_msgs::Point point(const se3::Vec3& v) {
  geometry_msgs::Point p;
  p.x = v.x();
  p.y = v.y();
  p.z = v.z();
  return p;
}

}  // namespace

visualization_msgs::Marker com_marker(const se3::Vec3& c, const std_msgs::Header& header) {
  visualization_msgs::Marker com;
  com.header = header;
  com.ns = "com";
  com.type = visualization_msgs::Marker::SPHERE;
  com.action = visualization_msgs::Marker::ADD;
  com.pose.position = point(c);
  com.pose.orientation.w = 1;
  com.scale.x = com.scale.y = com.scale.z = 0.05;
  com.color.r = 1.0;
  com.color.g = 0.8;
  com.color.a = 1.0;
  return com;
}

bool base_visual_marker(const se3::Scene& scene, const se3::SE3& base,
                        const std_msgs::Header& header, visualization_msgs::Marker& bus) {
  if (!scene.has_base_visual) return false;
  bus = visualization_msgs::Marker();
  bus.header = header;
  bus.ns = "base_visual";
  bus.type = visualization_msgs::Marker::CUBE;
  bus.action = visualization_msgs::Marker::ADD;
  bus.pose = to_pose(se3::SE3(base.R, base.act(scene.base_visual_origin)));
  const se3::Vec3& box = scene.base_visual_box;
  std::tie(bus.scale.x, bus.scale.y, bus.scale.z) = std::make_tuple(box.x(), box.y(), box.z());
  const se3::Vec3& rgb = scene.base_visual_color;
  std::tie(bus.color.r, bus.color.g, bus.color.b) = std::make_tuple(rgb.x(), rgb.y(), rgb.z());
  bus.color.a = 1.0;
  return true;
}

void append_torque_markers(const se3::Model& m, const std::vector<se3::SE3>& oMb,
                           const se3::VecX& act, const std_msgs::Header& header,
                           visualization_msgs::MarkerArray& out) {
  for (int i = 1; i <= m.n; ++i) {
    visualization_msgs::Marker a;
    a.header = header;
    a.ns = "torque";
    a.id = i;
    a.type = visualization_msgs::Marker::ARROW;
    const double e = act[m.idx_v(i)];
    if (e == 0) {
      a.action = visualization_msgs::Marker::DELETE;
      out.markers.push_back(a);
      continue;
    }
    a.action = visualization_msgs::Marker::ADD;
    const double lim = std::isfinite(m.effort[i]) && m.effort[i] > 0 ? m.effort[i] : 10.0;
    const se3::Vec3 o = oMb[i].p, axis = oMb[i].R.col(2) * (e > 0 ? 1.0 : -1.0);
    const se3::Vec3 tip = o + axis * (0.05 + 0.25 * std::min(1.0, std::abs(e) / lim));
    a.points = {point(o), point(tip)};
    a.pose.orientation.w = 1;
    a.scale.x = 0.01;
    a.scale.y = 0.02;
    a.scale.z = 0.03;
    a.color.r = e > 0 ? 1.0 : 0.2;
    a.color.b = e > 0 ? 0.2 : 1.0;
    a.color.a = 1.0;
    out.markers.push_back(a);
  }
}

void append_constraint_forces(const se3::Model& m, const std::vector<se3::ConstraintForce>& forces,
                              const std_msgs::Header& header, se3_sim::ConstraintForces& cf,
                              visualization_msgs::MarkerArray& markers) {
  cf.header = header;
  const double weight = std::max(m.total_mass() * 9.81, 1e-6);
  for (size_t k = 0; k < forces.size(); ++k) {
    const se3::ConstraintForce& f = forces[k];
    const bool ok = f.point.allFinite() && f.force.allFinite() && f.torque.allFinite();
    geometry_msgs::Point p;
    geometry_msgs::Vector3 F, T;
    if (ok) {
      p = point(f.point);
      F.x = f.force.x(), F.y = f.force.y(), F.z = f.force.z();
      T.x = f.torque.x(), T.y = f.torque.y(), T.z = f.torque.z();
    }
    cf.name.push_back(f.name);
    cf.kind.push_back(static_cast<uint8_t>(f.kind));
    cf.link.push_back(f.body >= 0 && f.body <= m.n ? m.body_name[f.body] : std::string());
    cf.point.push_back(p);
    cf.force.push_back(F);
    cf.torque.push_back(T);
    cf.joint_force.push_back(finite_or_zero(f.joint_force));
    cf.gap.push_back(finite_or_zero(f.gap));
    cf.active.push_back(ok && f.active);

    visualization_msgs::Marker a;
    a.header = header;
    a.ns = "constraint";
    a.id = static_cast<int>(k);
    a.type = visualization_msgs::Marker::ARROW;
    const double mag = ok ? f.force.norm() : 0.0;
    if (!(ok && f.active) || mag <= 0) {
      a.action = visualization_msgs::Marker::DELETE;
      markers.markers.push_back(a);
      continue;
    }
    a.action = visualization_msgs::Marker::ADD;
    const double len = std::min(0.6, std::max(0.02, 0.3 * mag / weight));
    a.points = {p, point(f.point + f.force / mag * len)};
    a.pose.orientation.w = 1;
    a.scale.x = 0.008;
    a.scale.y = 0.016;
    a.scale.z = 0.024;
    a.color.g = 0.9;
    a.color.b = f.kind == se3::ConstraintForce::Contact ? 0.2 : 0.9;
    a.color.a = 1.0;
    markers.markers.push_back(a);
  }
}

void sim_markers(se3::Simulator& sim, const se3::Scene& scene, const std_msgs::Header& header,
                 visualization_msgs::MarkerArray& out) {
  out.markers.push_back(com_marker(sim.center_of_mass(), header));
  append_object_markers(sim.object_specs(), sim.objects(), header.frame_id, header.stamp, out);
  visualization_msgs::Marker bus;
  if (base_visual_marker(scene, sim.state().base, header, bus)) out.markers.push_back(bus);
  // body_poses(): as center_of_mass() above left them.
  append_torque_markers(sim.model(), sim.body_poses(), sim.actuation(), header, out);
}

}  // namespace se3_ros
