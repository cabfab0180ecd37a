// The simulator node's world services and topics (world_services.h, docs/ros.md).
#include "se3_sim/ros/world_services.h"

#include <regex.h>
#include <ros/package.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>

#include "se3_sim/DeleteEntity.h"
#include "se3_sim/EntityCategory.h"
#include "se3_sim/GetEntities.h"
#include "se3_sim/GetEntitiesStates.h"
#include "se3_sim/GetEntityState.h"
#include "se3_sim/GetSimulationState.h"
#include "se3_sim/GetSimulatorFeatures.h"
#include "se3_sim/LinkStates.h"
#include "se3_sim/ModelStates.h"
#include "se3_sim/ResetSimulation.h"
#include "se3_sim/SetEntityState.h"
#include "se3_sim/SetSimulationState.h"
#include "se3_sim/SpawnEntity.h"
#include "se3_sim/StepSimulation.h"
#include "se3_sim/lie/format.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/ros/convert.h"
#include "se3_sim/ros/params.h"
#include "se3_sim/ros/renderer_convert.h"

namespace se3_ros {

namespace {

using Result = se3_sim::Result;
using Kind = se3::WorldError::Kind;

void fail(Result& r, std::uint8_t code, const std::string& why) {
  r.result = code;
  r.error_message = why;
}

void ok(Result& r, const std::string& note = "") {
  r.result = Result::RESULT_OK;
  r.error_message = note;
}

std::uint8_t code_of(Kind k) {
  switch (k) {
    case Kind::NotFound:
      return Result::RESULT_NOT_FOUND;
    case Kind::Stale:
      return Result::RESULT_INCORRECT_STATE;
    default:
      return Result::RESULT_OPERATION_FAILED;
  }
}

// A POSIX extended regular expression over entity names ("" matches every name).
class NameFilter {
 public:
  explicit NameFilter(const std::string& expr) : empty_(expr.empty()) {
    if (!empty_) ok_ = regcomp(&re_, expr.c_str(), REG_EXTENDED | REG_NOSUB) == 0;
  }
  ~NameFilter() {
    if (!empty_ && ok_) regfree(&re_);
  }
  NameFilter(const NameFilter&) = delete;
  NameFilter& operator=(const NameFilter&) = delete;
  bool valid() const { return empty_ || ok_; }
  bool match(const std::string& name) const {
    return empty_ || (ok_ && regexec(&re_, name.c_str(), 0, nullptr, 0) == 0);
  }

 private:
  bool empty_;
  bool ok_ = false;
  regex_t re_;
};

// spawn_entity's allow_renaming, as Gazebo's: `prepare` the edit; while it is refused for a name
// in use that `renamable` accepts, `rename` the entity NAME_1, NAME_2, ... (at most 1000 tries)
// and prepare again. The edit, or null when no free name was found; any other refusal is thrown.
template <class Prepare, class Renamable, class Rename>
se3::WorldEditPtr prepare_renaming(bool allow_renaming, Prepare prepare, Renamable renamable,
                                   Rename rename) {
  for (int suffix = 1; suffix <= 1000; ++suffix) {
    try {
      return prepare();
    } catch (const se3::WorldError& e) {
      if (!(allow_renaming && e.kind == Kind::NameInUse && renamable(e))) throw;
      rename(suffix);
    }
  }
  return nullptr;
}

std::uint8_t category_of(const se3::WorldModel& m) {
  if (m.kind == "robot") return se3_sim::EntityCategory::CATEGORY_ROBOT;
  return m.is_static ? se3_sim::EntityCategory::CATEGORY_STATIC
                     : se3_sim::EntityCategory::CATEGORY_OBJECT;
}

// Whether m passes the filters (the regex already checked valid).
bool passes(const se3::WorldModel& m, const NameFilter& names,
            const std::vector<std::uint8_t>& categories) {
  if (!names.match(m.name)) return false;
  if (categories.empty()) return true;
  return std::find(categories.begin(), categories.end(), category_of(m)) != categories.end();
}

bool all_zero(const geometry_msgs::Pose& p) {
  return p.position.x == 0 && p.position.y == 0 && p.position.z == 0 && p.orientation.x == 0 &&
         p.orientation.y == 0 && p.orientation.z == 0 && p.orientation.w == 0;
}

se3_sim::EntityState entity_state(const se3::SE3& pose, const se3::Vec6& twist,
                                  const std::string& frame, const ros::Time& stamp) {
  se3_sim::EntityState s;
  s.header.frame_id = frame;
  s.header.stamp = stamp;
  s.pose = to_pose(pose);
  s.twist = to_twist(twist);
  return s;
}

}  // namespace

struct WorldServices::Impl {
  ros::NodeHandle nh;
  WorldHooks hooks;
  std::string world_frame, base_dir;
  std::vector<ros::ServiceServer> services;
  ros::Publisher model_pub, link_pub, marker_pub;
  double rate = 50;
  std::chrono::steady_clock::time_point next_pub{};
  /// Held over a spawn's or delete's preparation and commit: one world edit at a time (the
  /// simulator's lock is taken only for the commit).
  std::mutex edit_mu;
  std::vector<std::string> spawned;  ///< names spawned since the start, for SCOPE_SPAWNED
  se3_sim::ModelStates models_msg;
  se3_sim::LinkStates links_msg;

  bool is_world(const std::string& frame) const { return frame.empty() || frame == world_frame; }

  // Markers of objects past the new count go stale in RViz (their ids are by index): delete
  // them (the next publication re-adds the rest).
  void delete_markers(std::size_t from, std::size_t to) {
    visualization_msgs::MarkerArray ma;
    for (std::size_t j = from; j < to; ++j) {
      for (int k = 0; k < 3; ++k) {
        visualization_msgs::Marker m;
        m.header.frame_id = world_frame;
        m.header.stamp = ros::Time::now();
        m.ns = "objects";
        m.id = static_cast<int>(3 * j) + k;
        m.action = visualization_msgs::Marker::DELETE;
        ma.markers.push_back(m);
      }
    }
    if (!ma.markers.empty()) marker_pub.publish(ma);
  }

  // A prepared edit committed under the node's lock; "" or the refusal. *report: the
  // interpenetration the new world starts with. *robot: a spawned robot's interface to insert
  // with the commit; out: a deleted robot's, for discard() off the lock (or the spawned one's
  // when the commit failed).
  std::string commit(se3::WorldEditPtr edit, std::string* report, std::size_t* objects_before,
                     std::size_t* objects_after, RobotInterfaces::RobotPtr* robot = nullptr) {
    std::string why;
    const se3::WorldEditInfo info = se3::edit_info(edit);
    hooks.with_sim([&](se3::Simulator& sim) {
      *objects_before = sim.object_specs().size();
      try {
        *report = sim.commit(std::move(edit));
        if (info.robot && hooks.robots && robot) {
          if (*robot) {
            hooks.robots->insert(std::move(*robot), sim);
            robot->reset();
          } else if (!info.deleted.empty()) {
            *robot = hooks.robots->remove(info.deleted, sim);
          }
        }
      } catch (const std::exception& e) {
        why = e.what();
      }
      *objects_after = sim.object_specs().size();
    });
    return why;
  }

  bool on_spawn(se3_sim::SpawnEntity::Request& req, se3_sim::SpawnEntity::Response& res) {
    using Srv = se3_sim::SpawnEntity::Response;
    const std::string& text = req.entity_resource.resource_string;
    const std::string& uri = req.entity_resource.uri;
    if (text.empty() && uri.empty()) {
      fail(res.result, Srv::NO_RESOURCE,
           "entity_resource: neither uri nor resource_string is given");
      return true;
    }
    if (!is_world(req.initial_pose.header.frame_id)) {
      fail(res.result, Result::RESULT_FEATURE_UNSUPPORTED,
           "initial_pose.header.frame_id '" + req.initial_pose.header.frame_id +
               "': only the world frame ('" + world_frame + "' or '') is taken");
      return true;
    }
    std::string yaml = text, source = "resource_string", dir = base_dir;
    if (yaml.empty() && uri.compare(0, 6, "param:") == 0) {
      // The name of a parameter holding the text (as spawn_model -param reads it).
      const std::string param = uri.substr(6);
      bool got = false;
      try {
        got = !param.empty() && nh.getParam(param, yaml);
      } catch (const ros::InvalidNameException&) {
      }
      if (!got || yaml.empty()) {
        fail(res.result, Srv::NO_RESOURCE,
             "entity_resource.uri '" + uri + "': no parameter of that name holding text");
        return true;
      }
      source = "parameter " + nh.resolveName(param);
    } else if (yaml.empty()) {
      std::string path = uri;
      if (path.compare(0, 7, "file://") == 0) path = path.substr(7);
      if (path.compare(0, 10, "package://") == 0) {
        const std::string rest = path.substr(10);
        const auto slash = rest.find('/');
        const std::string root = ros::package::getPath(rest.substr(0, slash));
        if (root.empty() || slash == std::string::npos) {
          fail(res.result, Srv::NO_RESOURCE,
               "entity_resource.uri '" + uri + "': no package '" + rest.substr(0, slash) + "'");
          return true;
        }
        path = root + rest.substr(slash);
      }
      // A URDF's bound (the larger; the scene reader bounds an object's YAML itself).
      std::string why;
      if (!se3::read_file(path, yaml, &why, se3::limits::kMaxUrdfBytes)) {
        fail(res.result, Srv::NO_RESOURCE, "entity_resource.uri '" + uri + "': " + why);
        return true;
      }
      source = path;
      const auto slash = path.find_last_of('/');
      if (slash != std::string::npos) dir = path.substr(0, slash);
    }
    if (yaml.find("<robot") != std::string::npos) return spawn_robot(req, res, yaml, source, dir);
    if (!req.entity_namespace.empty()) {
      fail(res.result, Srv::NAMESPACE_INVALID,
           "entity_namespace: objects have no namespace (only a URDF robot takes one)");
      return true;
    }
    std::lock_guard<std::mutex> edit_lock(edit_mu);
    // The name: the request's, else the resource's; a name in use gets a suffix when allowed.
    se3::SceneObject object;
    try {
      object = se3::parse_scene_object(yaml, dir, source, req.name.empty() ? "" : req.name);
    } catch (const std::exception& e) {
      const std::string why = e.what();
      fail(res.result,
           why.find("not found") != std::string::npos ? Srv::MISSING_ASSETS
                                                      : Srv::RESOURCE_PARSE_ERROR,
           why);
      return true;
    }
    if (!all_zero(req.initial_pose.pose)) {
      const std::string why = from_pose(req.initial_pose.pose, object.pose);
      if (!why.empty()) {
        fail(res.result, Srv::INVALID_POSE, "initial_pose: " + why);
        return true;
      }
    }
    // Preparation off the simulator's lock: shapes, collision model, constraint system.
    se3::WorldEditPtr edit;
    std::string why;
    std::uint8_t code = Result::RESULT_OK;
    const std::string base = object.name;
    try {
      edit = prepare_renaming(
          req.allow_renaming, [&] { return prepare(object); },
          [](const se3::WorldError&) { return true; },
          [&](int suffix) {
            object.name = object.material.name = base + "_" + std::to_string(suffix);
          });
    } catch (const se3::WorldError& e) {
      why = e.what();
      code = e.kind == Kind::NameInUse     ? std::uint8_t(Srv::NAME_NOT_UNIQUE)
             : e.kind == Kind::NameInvalid ? std::uint8_t(Srv::NAME_INVALID)
             : e.kind == Kind::InvalidPose ? std::uint8_t(Srv::INVALID_POSE)
                                           : std::uint8_t(Result::RESULT_OPERATION_FAILED);
    } catch (const std::exception& e) {
      why = e.what();
      code = Result::RESULT_OPERATION_FAILED;
    }
    if (!edit) {
      fail(res.result, code, why.empty() ? "no free name" : why);
      return true;
    }
    std::string report;
    std::size_t before = 0, after = 0;
    why = commit(std::move(edit), &report, &before, &after);
    if (!why.empty()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED, why);
      return true;
    }
    spawned.push_back(object.name);
    res.entity_name = object.name;
    ok(res.result, report);
    ROS_INFO("simulator: spawned object '%s'%s%s", object.name.c_str(), report.empty() ? "" : ": ",
             report.c_str());
    return true;
  }

  static std::string urdf_robot_name(const std::string& urdf) {
    try {
      return se3::model_from_urdf_string(urdf).name;
    } catch (const std::exception&) {
      return "robot";
    }
  }

  // A URDF robot (spawn_entity with a <robot> resource): parsed and built off the simulator's
  // lock, its topics advertised off it too, both swapped in under it.
  bool spawn_robot(se3_sim::SpawnEntity::Request& req, se3_sim::SpawnEntity::Response& res,
                   const std::string& urdf, const std::string& source, const std::string& dir) {
    using Srv = se3_sim::SpawnEntity::Response;
    if (!hooks.robots) {
      fail(res.result, Srv::UNSUPPORTED_FORMAT,
           "entity_resource: a URDF robot; this node does not spawn robots");
      return true;
    }
    se3::RobotSpawn spawn;
    spawn.urdf = urdf;
    spawn.name = req.name;
    spawn.ns = req.entity_namespace;
    // Its collision meshes (a scene with collision) as the markers find them: package:// by
    // rospack, relative names beside the URDF file (or the scene).
    spawn.geometry.resolver = se3::ros_renderer::ros_resolver(dir);
    if (!all_zero(req.initial_pose.pose)) {
      const std::string why = from_pose(req.initial_pose.pose, spawn.pose);
      if (!why.empty()) {
        fail(res.result, Srv::INVALID_POSE, "initial_pose: " + why);
        return true;
      }
    }
    std::lock_guard<std::mutex> edit_lock(edit_mu);
    const se3::Simulator* sim = nullptr;
    hooks.with_sim([&](se3::Simulator& s) { sim = &s; });
    se3::WorldEditPtr edit;
    std::string why;
    std::uint8_t code = Result::RESULT_OK;
    std::string base;  // the name suffixes go on (allow_renaming)
    try {
      // Off the simulator's lock, as prepare() for objects.
      edit = prepare_renaming(
          req.allow_renaming, [&] { return sim->prepare_spawn_robot(spawn); },
          // The robot's name in use (not its namespace): renamed.
          [](const se3::WorldError& e) {
            return std::string(e.what()).compare(0, 5, "name ") == 0;
          },
          [&](int suffix) {
            // The URDF's robot name when the request has none (the URDF parsed a moment ago).
            if (base.empty()) base = req.name.empty() ? urdf_robot_name(urdf) : req.name;
            spawn.name = base + "_" + std::to_string(suffix);
          });
    } catch (const se3::WorldError& e) {
      // The request's field, then the library's line (which names its own field).
      why = e.what();
      const bool ns = why.compare(0, 10, "namespace ") == 0;
      switch (e.kind) {
        case Kind::Resource:
          // A collision mesh that did not load (a scene with collision) is a missing asset.
          code = why.find("contact needs it") != std::string::npos ? Srv::MISSING_ASSETS
                                                                   : Srv::RESOURCE_PARSE_ERROR;
          why = "entity_resource (" + source + "): " + why;
          break;
        case Kind::NameInUse:
        case Kind::NameInvalid:
          code = ns                          ? Srv::NAMESPACE_INVALID
                 : e.kind == Kind::NameInUse ? Srv::NAME_NOT_UNIQUE
                                             : Srv::NAME_INVALID;
          why = (ns ? "entity_namespace: " : "name: ") + why;
          break;
        case Kind::InvalidPose:
          code = Srv::INVALID_POSE;
          why = "initial_pose: " + why;
          break;
        default:
          code = Result::RESULT_OPERATION_FAILED;
      }
    } catch (const std::exception& e) {
      why = e.what();
      code = Result::RESULT_OPERATION_FAILED;
    }
    if (!edit) {
      fail(res.result, code, why.empty() ? "name: no free name" : why);
      return true;
    }
    const se3::WorldEditInfo info = se3::edit_info(edit);
    RobotInterfaces::RobotPtr robot;
    try {
      robot = hooks.robots->prepare(*info.robot_model, info.spawned, spawn.ns, urdf);
    } catch (const std::exception& e) {
      fail(res.result, Srv::NAMESPACE_INVALID,
           "entity_namespace '" + req.entity_namespace + "': " + e.what());
      return true;
    }
    std::string report;
    std::size_t before = 0, after = 0;
    why = commit(std::move(edit), &report, &before, &after, &robot);
    if (!why.empty()) {
      hooks.robots->discard(std::move(robot));
      fail(res.result, Result::RESULT_OPERATION_FAILED, why);
      return true;
    }
    spawned.push_back(info.spawned);
    res.entity_name = info.spawned;
    ok(res.result, report);
    ROS_INFO("simulator: spawned robot '%s' (%s)%s%s", info.spawned.c_str(), source.c_str(),
             report.empty() ? "" : ": ", report.c_str());
    return true;
  }

  // The simulator's prepare_spawn, which reads only what commits change (commits are serialized
  // by edit_mu, held by the caller): no simulator lock needed while it builds.
  se3::WorldEditPtr prepare(const se3::SceneObject& o) {
    if (o.name == world_frame) {
      throw se3::WorldError(Kind::NameInvalid, "name '" + o.name + "' is the world frame's");
    }
    se3::WorldEditPtr e;
    const se3::Simulator* sim = nullptr;
    hooks.with_sim([&](se3::Simulator& s) { sim = &s; });
    e = sim->prepare_spawn(o);
    return e;
  }

  bool on_delete(se3_sim::DeleteEntity::Request& req, se3_sim::DeleteEntity::Response& res) {
    std::lock_guard<std::mutex> edit_lock(edit_mu);
    const se3::Simulator* sim = nullptr;
    hooks.with_sim([&](se3::Simulator& s) { sim = &s; });
    se3::WorldEditPtr edit;
    try {
      edit = sim->prepare_delete(req.entity);
    } catch (const se3::WorldError& e) {
      fail(res.result, code_of(e.kind), std::string("entity: ") + e.what());
      return true;
    }
    std::string report;
    std::size_t before = 0, after = 0;
    RobotInterfaces::RobotPtr robot;
    const std::string why = commit(std::move(edit), &report, &before, &after, &robot);
    if (hooks.robots) hooks.robots->discard(std::move(robot));  // off the lock
    if (!why.empty()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED, why);
      return true;
    }
    spawned.erase(std::remove(spawned.begin(), spawned.end(), req.entity), spawned.end());
    delete_markers(after, before);
    ok(res.result);
    ROS_INFO("simulator: deleted '%s'", req.entity.c_str());
    return true;
  }

  bool on_get_entities(se3_sim::GetEntities::Request& req, se3_sim::GetEntities::Response& res) {
    const NameFilter names(req.filters.filter);
    if (!names.valid()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED,
           "filters.filter '" + req.filters.filter + "' is not a POSIX extended regex");
      return true;
    }
    std::vector<se3::WorldModel> models;
    std::string robot0;
    hooks.with_sim([&](se3::Simulator& sim) {
      models = sim.world_models();
      robot0 = sim.robot_name();
    });
    for (const se3::WorldModel& m : models) {
      if (!passes(m, names, req.filters.categories)) continue;
      res.entities.push_back(m.name);
      res.categories.push_back(category_of(m));
      // A robot 1.. without a namespace has its topics under its name (robot_interfaces.h).
      const bool named = m.kind == "robot" && m.ns.empty() && m.name != robot0;
      res.namespaces.push_back(named ? m.name : m.ns);
    }
    ok(res.result);
    return true;
  }

  bool on_get_state(se3_sim::GetEntityState::Request& req, se3_sim::GetEntityState::Response& res) {
    const std::string ref = is_world(req.reference_frame) ? "" : req.reference_frame;
    std::string why;
    Kind kind = Kind::Invalid;
    hooks.with_sim([&](se3::Simulator& sim) {
      const ros::Time stamp = ros::Time(sim.time());
      try {
        if (ref.empty() && req.entity.find("::") == std::string::npos) {
          // A model, else a link of that name.
          bool model = false;
          for (const se3::WorldModel& m : sim.world_models()) model = model || m.name == req.entity;
          if (model) {
            const se3::ModelState s = sim.model_state(req.entity);
            res.state = entity_state(s.pose, s.twist, world_frame, stamp);
            return;
          }
        }
        const se3::LinkState s = sim.link_state(req.entity, ref);
        res.state = entity_state(s.pose, s.twist, ref.empty() ? world_frame : ref, stamp);
      } catch (const se3::WorldError& e) {
        why = e.what();
        kind = e.kind;
      }
    });
    if (!why.empty()) {
      fail(res.result, code_of(kind), why);
    } else {
      ok(res.result);
    }
    return true;
  }

  bool on_set_state(se3_sim::SetEntityState::Request& req, se3_sim::SetEntityState::Response& res) {
    if (!is_world(req.state.header.frame_id)) {
      fail(res.result, Result::RESULT_FEATURE_UNSUPPORTED,
           "state.header.frame_id '" + req.state.header.frame_id + "': only the world frame ('" +
               world_frame + "' or '') is taken");
      return true;
    }
    se3::SE3 pose;
    const std::string bad = from_pose(req.state.pose, pose);
    if (!bad.empty()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED, "state.pose: " + bad);
      return true;
    }
    const se3::Vec6 twist = from_twist(req.state.twist);
    if (!twist.allFinite()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED, "state.twist has a non-finite number");
      return true;
    }
    // A static object's new place rebuilds the collision model: one edit at a time.
    std::lock_guard<std::mutex> edit_lock(edit_mu);
    std::string why, report;
    Kind kind = Kind::Invalid;
    hooks.with_sim([&](se3::Simulator& sim) {
      try {
        bool model = false;
        for (const se3::WorldModel& m : sim.world_models()) model = model || m.name == req.entity;
        if (model) {
          se3::ModelState s = sim.model_state(req.entity);
          s.pose = pose;
          s.twist = twist;
          report = sim.set_model_state(req.entity, s);
        } else {
          se3::LinkState s;
          s.pose = pose;
          s.twist = twist;
          report = sim.set_link_state(req.entity, s);
        }
      } catch (const se3::WorldError& e) {
        why = e.what();
        kind = e.kind;
      }
    });
    if (!why.empty()) {
      fail(res.result, code_of(kind), why);
    } else {
      ok(res.result, report);
    }
    return true;
  }

  bool on_get_states(se3_sim::GetEntitiesStates::Request& req,
                     se3_sim::GetEntitiesStates::Response& res) {
    const NameFilter names(req.filters.filter);
    if (!names.valid()) {
      fail(res.result, Result::RESULT_OPERATION_FAILED,
           "filters.filter '" + req.filters.filter + "' is not a POSIX extended regex");
      return true;
    }
    hooks.with_sim([&](se3::Simulator& sim) {
      const ros::Time stamp = ros::Time(sim.time());
      for (const se3::WorldModel& m : sim.world_models()) {
        if (!passes(m, names, req.filters.categories)) continue;
        const se3::ModelState s = sim.model_state(m.name);
        res.entities.push_back(m.name);
        res.states.push_back(entity_state(s.pose, s.twist, world_frame, stamp));
      }
    });
    ok(res.result);
    return true;
  }

  bool on_step(se3_sim::StepSimulation::Request& req, se3_sim::StepSimulation::Response& res) {
    std::string why;
    if (hooks.step(req.steps, &why)) {
      ok(res.result, why);
    } else {
      fail(res.result,
           why.find("running") != std::string::npos ? Result::RESULT_INCORRECT_STATE
                                                    : Result::RESULT_OPERATION_FAILED,
           why);
    }
    return true;
  }

  // Deletes the spawned objects (edit_mu held).
  std::string delete_spawned() {
    std::string why;
    for (const std::string& name : std::vector<std::string>(spawned)) {
      const se3::Simulator* sim = nullptr;
      hooks.with_sim([&](se3::Simulator& s) { sim = &s; });
      se3::WorldEditPtr edit;
      try {
        edit = sim->prepare_delete(name);
      } catch (const std::exception&) {
        continue;  // deleted already
      }
      std::string report;
      std::size_t before = 0, after = 0;
      RobotInterfaces::RobotPtr robot;
      why = commit(std::move(edit), &report, &before, &after, &robot);
      if (hooks.robots) hooks.robots->discard(std::move(robot));
      if (!why.empty()) return why;
      delete_markers(after, before);
    }
    spawned.clear();
    return "";
  }

  bool on_reset(se3_sim::ResetSimulation::Request& req, se3_sim::ResetSimulation::Response& res) {
    using R = se3_sim::ResetSimulation::Request;
    std::uint8_t scope = req.scope;
    if (scope == R::SCOPE_DEFAULT) scope = R::SCOPE_ALL;
    const bool time = scope & R::SCOPE_TIME, state = scope & R::SCOPE_STATE,
               spawned_too = scope & R::SCOPE_SPAWNED;
    if (time && !state) {
      fail(res.result, Result::RESULT_FEATURE_UNSUPPORTED,
           "scope: SCOPE_TIME needs SCOPE_STATE (the state of time 0 is the initial state)");
      return true;
    }
    std::lock_guard<std::mutex> edit_lock(edit_mu);
    if (spawned_too) {
      const std::string why = delete_spawned();
      if (!why.empty()) {
        fail(res.result, Result::RESULT_OPERATION_FAILED, why);
        return true;
      }
    }
    if (state) {
      hooks.with_sim([&](se3::Simulator& sim) {
        if (time) {
          sim.reset();
        } else {
          sim.reset_world();
        }
        hooks.after_reset(!time);
      });
    }
    ok(res.result, time    ? "reset to the initial state, time 0"
                   : state ? "world reset to the initial state; time runs on"
                           : "spawned entities deleted");
    return true;
  }

  bool on_features(se3_sim::GetSimulatorFeatures::Request&,
                   se3_sim::GetSimulatorFeatures::Response& res) {
    using F = se3_sim::SimulatorFeatures;
    res.features.features = {F::SPAWNING,
                             F::DELETING,
                             F::ENTITY_CATEGORIES,
                             F::SPAWNING_RESOURCE_STRING,
                             F::ENTITY_STATE_GETTING,
                             F::ENTITY_STATE_SETTING,
                             F::SIMULATION_RESET,
                             F::SIMULATION_RESET_TIME,
                             F::SIMULATION_RESET_STATE,
                             F::SIMULATION_RESET_SPAWNED,
                             F::SIMULATION_STATE_GETTING,
                             F::SIMULATION_STATE_SETTING,
                             F::SIMULATION_STATE_PAUSE,
                             F::STEP_SIMULATION_SINGLE,
                             F::STEP_SIMULATION_MULTIPLE};
    res.features.spawn_formats = {"se3_sim_object", "urdf"};
    res.features.custom_info =
        "se3_sim world services (docs/ros.md): objects spawn from the YAML keys of a scene's "
        "objects: entry, robots from a URDF (uri param:NAME: a parameter holding it); links are "
        "entities named MODEL::LINK";
    return true;
  }

  bool on_set_sim_state(se3_sim::SetSimulationState::Request& req,
                        se3_sim::SetSimulationState::Response& res) {
    using S = se3_sim::SimulationState;
    using Srv = se3_sim::SetSimulationState::Response;
    const std::uint8_t want = req.state.state;
    if (want == S::STATE_QUITTING) {
      fail(res.result, Result::RESULT_FEATURE_UNSUPPORTED,
           "state: STATE_QUITTING (stop the node as any ROS node)");
      return true;
    }
    if (want != S::STATE_PLAYING && want != S::STATE_PAUSED && want != S::STATE_STOPPED) {
      fail(res.result, Result::RESULT_OPERATION_FAILED,
           "state: unknown state " + std::to_string(want));
      return true;
    }
    std::string why;
    std::uint8_t code = Result::RESULT_OK;
    hooks.with_sim([&](se3::Simulator& sim) {
      const bool paused = hooks.paused();
      if (want == S::STATE_PLAYING) {
        if (!sim.failure().empty()) {
          code = Srv::STATE_TRANSITION_ERROR;
          why = "diverged (" + sim.failure() + "); reset first";
          return;
        }
        if (!paused) code = Srv::ALREADY_IN_TARGET_STATE;
        hooks.set_paused(false);
      } else if (want == S::STATE_PAUSED) {
        if (paused) code = Srv::ALREADY_IN_TARGET_STATE;
        hooks.set_paused(true);
      } else {
        hooks.set_paused(true);
        sim.reset();
        hooks.after_reset(false);
      }
    });
    if (code == Result::RESULT_OK) {
      ok(res.result);
    } else {
      fail(res.result, code, why.empty() ? "already in that state" : why);
    }
    return true;
  }

  bool on_get_sim_state(se3_sim::GetSimulationState::Request&,
                        se3_sim::GetSimulationState::Response& res) {
    hooks.with_sim([&](se3::Simulator&) {
      res.state.state = hooks.paused() ? se3_sim::SimulationState::STATE_PAUSED
                                       : se3_sim::SimulationState::STATE_PLAYING;
    });
    ok(res.result);
    return true;
  }

  void publish(se3::Simulator& sim) {
    models_msg.name.clear();
    models_msg.pose.clear();
    models_msg.twist.clear();
    for (const se3::WorldModel& m : sim.world_models()) {
      const se3::ModelState s = sim.model_state(m.name);
      models_msg.name.push_back(m.name);
      models_msg.pose.push_back(to_pose(s.pose));
      models_msg.twist.push_back(to_twist(s.twist));
    }
    model_pub.publish(models_msg);
    links_msg.name.clear();
    links_msg.pose.clear();
    links_msg.twist.clear();
    const std::string robot = sim.robot_name();
    for (const std::string& link : sim.link_names()) {
      const bool object = std::find(models_msg.name.begin(), models_msg.name.end(), link) !=
                              models_msg.name.end() &&
                          link != robot;
      const std::string full = link.find("::") != std::string::npos  // a robot 1..'s
                                   ? link
                                   : (object ? link : robot) + "::" + link;
      const se3::LinkState s = sim.link_state(full);
      links_msg.name.push_back(full);
      links_msg.pose.push_back(to_pose(s.pose));
      links_msg.twist.push_back(to_twist(s.twist));
    }
    link_pub.publish(links_msg);
  }
};

WorldServices::WorldServices(ros::NodeHandle nh, ros::NodeHandle pnh, WorldHooks hooks,
                             std::string world_frame, std::string base_dir)
    : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.nh = nh;
  w.hooks = std::move(hooks);
  w.world_frame = std::move(world_frame);
  w.base_dir = std::move(base_dir);
  w.rate = get_double(pnh, "world_states_rate").value_or(50.0);
  if (!(w.rate >= 0) || !std::isfinite(w.rate)) {
    ROS_WARN("simulator: ~world_states_rate %g is not a rate >= 0: 50 Hz", w.rate);
    w.rate = 50;
  }
  if (w.rate > 0) {
    w.model_pub = nh.advertise<se3_sim::ModelStates>("model_states", 10);
    w.link_pub = nh.advertise<se3_sim::LinkStates>("link_states", 10);
  }
  w.marker_pub = nh.advertise<visualization_msgs::MarkerArray>("sim_markers", 10);
  auto& s = w.services;
  s.push_back(nh.advertiseService("simulator/spawn_entity", &Impl::on_spawn, &w));
  s.push_back(nh.advertiseService("simulator/delete_entity", &Impl::on_delete, &w));
  s.push_back(nh.advertiseService("simulator/get_entities", &Impl::on_get_entities, &w));
  s.push_back(nh.advertiseService("simulator/get_entity_state", &Impl::on_get_state, &w));
  s.push_back(nh.advertiseService("simulator/set_entity_state", &Impl::on_set_state, &w));
  s.push_back(nh.advertiseService("simulator/get_entities_states", &Impl::on_get_states, &w));
  s.push_back(nh.advertiseService("simulator/step_simulation", &Impl::on_step, &w));
  s.push_back(nh.advertiseService("simulator/reset_simulation", &Impl::on_reset, &w));
  s.push_back(nh.advertiseService("simulator/get_simulator_features", &Impl::on_features, &w));
  s.push_back(nh.advertiseService("simulator/set_simulation_state", &Impl::on_set_sim_state, &w));
  s.push_back(nh.advertiseService("simulator/get_simulation_state", &Impl::on_get_sim_state, &w));
}

WorldServices::~WorldServices() = default;

void WorldServices::publish(se3::Simulator& sim, std::chrono::steady_clock::time_point now,
                            const ros::Time&) {
  Impl& w = *impl_;
  if (!(w.rate > 0) || now < w.next_pub) return;
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / w.rate));
  w.next_pub = w.next_pub + period <= now ? now + period : w.next_pub + period;
  w.publish(sim);
}

}  // namespace se3_ros
