// The renderer node: draws the robot described by `robot_description` (its visual meshes, resolved
// through ROS's package lookup), posed from TF, and publishes the image through image_transport
// as renderer/image with renderer/camera_info (1280x1024 rgb8 by default), only while someone
// subscribes; the same geometry goes to RViz as renderer/markers (MESH_RESOURCE markers with
// the meshes' package:// names). An adapter over se3_sim_render (include/se3_sim/render/render.h;
// the camera command convention is documented there) and src/ros/renderer_convert.h.
//
// Parameters (private): ~rate (Hz, 30), ~width (1280), ~height (1024), ~focal_px (1000),
// ~eye [x, y, z] and ~target [x, y, z] (default: framed on the robot), ~fixed_frame ("world"),
// ~follow_frame ("": a TF frame the camera keeps its offset to, e.g. the base of a falling
// robot), ~save_dir ("/tmp"), ~show_frames (false), ~grid_spacing (0.5), ~threads (2: rows
// shared by two threads), ~simplify_error (m, 0.0005: mesh simplification bound, 0 = off),
// ~camera_frame ("renderer_camera_optical", broadcast on TF so others can project into the
// image).
// Subscribes: robot_description (param, re-read until it parses), /tf, sim_markers,
// renderer/camera_command (geometry_msgs/Twist), sim_stats, torque_command (overlay). The
// sim_markers' shapes are drawn, MESH_RESOURCE ones (scene mesh objects) with their triangles,
// loaded once per resource through the same resolver (a mesh that fails: one warning and a
// stand-in cube).
// Service: renderer/save_frame (std_srvs/Trigger): renders and writes the frame as a new PNG in
// ~save_dir (never over an earlier one); the message is the path written.
#include "se3_sim/ros/renderer_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <se3_sim/JointTorques.h>
#include <se3_sim/SimStats.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/render/render.h"
#include "se3_sim/ros/renderer_convert.h"

namespace {

using se3::Mat3;
using se3::SE3;
using se3::Vec3;
namespace rn = se3::render;
namespace rr = se3::ros_renderer;

bool read_vec3(ros::NodeHandle& pnh, const std::string& name, Vec3& out) {
  std::vector<double> v;
  if (!pnh.getParam(name, v)) return false;
  if (v.size() != 3 || !std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
    ROS_WARN("renderer: ~%s must be a list of 3 numbers; ignored", name.c_str());
    return false;
  }
  out = Vec3(v[0], v[1], v[2]);
  return true;
}

}  // namespace

namespace se3_ros {

class RendererNodeImpl {
 public:
  RendererNodeImpl() : pnh_("~"), it_(nh_), tf_listener_(tf_buffer_) {
    pnh_.param("rate", rate_, 30.0);
    if (!(rate_ > 0) || !std::isfinite(rate_) || rate_ > 120) {
      ROS_WARN("renderer: ~rate %g out of (0, 120]; using 30", rate_);
      rate_ = 30;
    }
    rn::Camera cam;
    pnh_.param("width", cam.width, 1280);
    pnh_.param("height", cam.height, 1024);
    pnh_.param("focal_px", cam.focal_px, 1000.0);
    if (cam.width < 16 || cam.height < 16 || cam.width > 8192 || cam.height > 8192) {
      ROS_WARN("renderer: image size %dx%d out of range; using 1280x1024", cam.width, cam.height);
      cam.width = 1280;
      cam.height = 1024;
    }
    user_camera_ = read_vec3(pnh_, "eye", cam.eye);
    user_camera_ = read_vec3(pnh_, "target", cam.target) || user_camera_;
    if (!cam.update()) ROS_WARN("renderer: degenerate camera parameters; corrected");
    pnh_.param<std::string>("fixed_frame", fixed_frame_, "world");
    fixed_frame_ = se3::frame_name(fixed_frame_);
    pnh_.param<std::string>("follow_frame", follow_frame_, "");
    follow_frame_ = se3::frame_name(follow_frame_);
    pnh_.param<std::string>("save_dir", save_dir_, "/tmp");
    pnh_.param<std::string>("camera_frame", camera_frame_, "renderer_camera_optical");
    pnh_.param("simplify_error", draw_.simplify_error, draw_.simplify_error);
    marker_meshes_ = rr::MarkerMeshes(rr::ros_resolver(), draw_);
    renderer_ = std::make_unique<rn::Renderer>(cam);
    camera_ = renderer_->camera();
    pnh_.param("show_frames", renderer_->style().frames, false);
    int threads = 2;
    pnh_.param("threads", threads, 2);
    renderer_->style().threads = threads >= 2 ? 2 : 1;
    double spacing = 0.5;
    pnh_.param("grid_spacing", spacing, 0.5);
    if (spacing > 0 && std::isfinite(spacing)) renderer_->style().grid_spacing = spacing;

    image_.height = cam.height;
    image_.width = cam.width;
    image_.encoding = "rgb8";
    image_.is_bigendian = 0;
    image_.step = cam.width * 3;
    image_.data.resize(std::size_t(image_.step) * cam.height);

    camera_pub_ = it_.advertiseCamera("renderer/image", 2);
    markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("renderer/markers", 2);
    sim_markers_sub_ = nh_.subscribe("sim_markers", 10, &RendererNodeImpl::on_sim_markers, this);
    camera_sub_ = nh_.subscribe("renderer/camera_command", 20, &RendererNodeImpl::on_camera, this);
    stats_sub_ = nh_.subscribe("sim_stats", 5, &RendererNodeImpl::on_stats, this);
    torque_sub_ = nh_.subscribe("torque_command", 5, &RendererNodeImpl::on_torque, this);
    save_srv_ = nh_.advertiseService("renderer/save_frame", &RendererNodeImpl::on_save, this);
    timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / rate_), &RendererNodeImpl::on_timer, this);
    ROS_INFO("renderer: %dx%d at %.1f Hz in frame '%s'%s%s", cam.width, cam.height, rate_,
             fixed_frame_.c_str(), follow_frame_.empty() ? "" : ", following ",
             follow_frame_.c_str());
  }

 private:
  // ---------------------------------------------------------------- model
  void load_model() {
    const ros::WallTime now = ros::WallTime::now();
    if (model_ || (now - last_model_try_).toSec() < 1.0) return;
    last_model_try_ = now;
    std::string xml;
    if (!nh_.getParam("robot_description", xml) || xml.empty()) {
      ROS_WARN_THROTTLE(10, "renderer: no robot_description yet; drawing the ground only");
      return;
    }
    if (xml == failed_xml_) return;
    try {
      // Bodies are posed from TF, so the base type does not matter here; a fixed base also
      // accepts robots whose root link is massless (which a free base must not be).
      se3::UrdfOptions opt;
      opt.floating = false;
      const se3::UrdfDocument doc = se3::parse_urdf_document(xml);  // once, for both
      auto m = std::make_unique<se3::Model>(se3::model_from_urdf(doc, opt));
      se3::GeometryOptions gopt;
      // Relative mesh names: beside the URDF of sim.launch's robot:= (robot_description_dir).
      std::string dir;
      nh_.getParam("robot_description_dir", dir);
      gopt.resolver = rr::ros_resolver(dir);
      const se3::GeometryModel geometry = se3::geometry_from_urdf(*m, doc, gopt);
      for (const std::string& w : se3::summarize_mesh_warnings(geometry.warnings)) {
        ROS_WARN("renderer: %s", w.c_str());
      }
      renderer_->set_model(*m, geometry, draw_);
      poses_.assign(m->parent.size(),
                    SE3(Mat3::Constant(std::nan("")), Vec3::Constant(std::nan(""))));
      offsets_inv_.assign(m->parent.size(), SE3());
      for (std::size_t i = 0; i < m->body_name.size() && i < offsets_inv_.size(); ++i) {
        const int li = m->link_index(m->body_name[i]);
        if (li >= 0) offsets_inv_[i] = m->links[li].offset.inverse();
      }
      item_offsets_inv_.clear();
      for (const rn::DrawItem& it : renderer_->items()) {
        const int li = m->link_index(it.link);
        item_offsets_inv_.push_back(li >= 0 ? m->links[li].offset.inverse() : SE3());
      }
      std::size_t tris = 0, source = 0;
      for (const rn::DrawItem& it : renderer_->items()) {
        tris += it.mesh->triangle_count();
        // Only meshes read from files: primitives and stand-ins are tessellated here.
        if (it.shape == se3::ShapeType::Mesh && !it.stand_in) source += it.mesh->source_triangles;
      }
      model_ = std::move(m);
      // "in the files" only when mesh files were loaded (primitives and stand-ins are not).
      const std::string files = source > 0 ? " (" + std::to_string(source) + " in the mesh files)"
                                           : " (no mesh file loaded)";
      ROS_INFO("renderer: model '%s' with %d bodies, %zu visuals, %zu triangles%s",
               model_->name.c_str(), int(model_->parent.size()), renderer_->items().size(), tris,
               files.c_str());
    } catch (const std::exception& e) {
      failed_xml_ = xml;
      ROS_ERROR("renderer: robot_description rejected: %s", e.what());
    }
  }

  void update_poses() {
    if (!model_) return;
    bool any_new = false;
    for (std::size_t i = 0; i < poses_.size() && i < model_->body_name.size(); ++i) {
      try {
        const auto t = tf_buffer_.lookupTransform(fixed_frame_, model_->body_name[i], ros::Time(0));
        const SE3 link = rr::to_se3(t.transform);
        if (link.R.allFinite() && link.p.allFinite()) {
          poses_[i] = link * offsets_inv_[i];  // link frame = body frame * offset
          any_new = true;
        }
      } catch (const tf2::TransformException& e) {
        ROS_WARN_THROTTLE(10, "renderer: no TF %s -> %s yet (%s); body hidden",
                          fixed_frame_.c_str(), model_->body_name[i].c_str(), e.what());
      }
    }
    if (any_new && !framed_ && !user_camera_) {
      rn::Camera cam = camera_;
      rn::frame_items(renderer_->items(), poses_, cam, convert_markers());
      camera_ = cam;
      framed_ = true;
      follow_.set_camera(camera_, follow_origin());
    }
  }

  // The follow frame's origin in the fixed frame (NaN when unknown or not following).
  Vec3 follow_origin() {
    if (follow_frame_.empty()) return Vec3::Constant(std::nan(""));
    try {
      return rr::to_se3(
                 tf_buffer_.lookupTransform(fixed_frame_, follow_frame_, ros::Time(0)).transform)
          .p;
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(10, "renderer: no TF %s -> %s (follow_frame) yet: %s", fixed_frame_.c_str(),
                        follow_frame_.c_str(), e.what());
      return Vec3::Constant(std::nan(""));
    }
  }

  // ---------------------------------------------------------------- inputs
  void on_sim_markers(const visualization_msgs::MarkerArray::ConstPtr& msg) {
    const rr::SimMarkers::Update up = sim_markers_.apply(*msg, marker_meshes_);
    // A box or mesh that is new (e.g. the scene's satellite bus, a mesh object) is solid
    // geometry: frame it too.
    if (up.new_solid) framed_ = false;
    for (const std::string& w : up.warnings) ROS_WARN("renderer: %s", w.c_str());
    if (up.dropped) {
      ROS_WARN_THROTTLE(10, "renderer: sim_markers: %zu new markers dropped (%zu kept at most)",
                        up.dropped, rr::SimMarkers::kMaxMarkers);
    }
  }

  void on_camera(const geometry_msgs::Twist::ConstPtr& msg) {
    rr::apply_camera_command(*msg, camera_);
    framed_ = true;  // the user steers now
    follow_.set_camera(camera_, follow_origin());
  }

  void on_stats(const se3_sim::SimStats::ConstPtr& msg) {
    overlay_.sim_time = msg->sim_time;
    overlay_.real_time_factor = msg->real_time_factor;
    overlay_.lines.clear();
    if (msg->paused) overlay_.lines.push_back("paused");
    if (!msg->status.empty()) overlay_.lines.push_back(msg->status.substr(0, 80));
  }

  void on_torque(const se3_sim::JointTorques::ConstPtr& msg) {
    // The selected joint is the one teleop drives: the largest commanded effort.
    double best = 0;
    std::string joint;
    for (std::size_t i = 0; i < msg->name.size() && i < msg->effort.size(); ++i) {
      if (std::isfinite(msg->effort[i]) && std::abs(msg->effort[i]) >= std::abs(best) &&
          (msg->effort[i] != 0 || joint.empty())) {
        best = msg->effort[i];
        joint = msg->name[i];
      }
    }
    overlay_.joint = joint;
    overlay_.torque = joint.empty() ? std::nan("") : best;
  }

  bool on_save(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    std::string err;
    const std::string path = rr::reserve_frame_path(save_dir_, saved_, &err);
    if (path.empty()) {
      res.success = false;
      res.message = err;
      return true;
    }
    try {
      render_frame();
    } catch (const std::exception& e) {
      res.success = false;
      res.message = std::string("frame not rendered: ") + e.what();
      return true;
    }
    res.success = renderer_->write_png(path, &err);
    res.message = res.success ? path : err;
    if (res.success) ROS_INFO("renderer: saved %s", path.c_str());
    return true;
  }

  // ---------------------------------------------------------------- markers
  std::vector<rn::Marker> convert_markers() {
    std::vector<rn::Marker> out;
    for (const auto& kv : sim_markers_.markers()) {
      const visualization_msgs::Marker& m = kv.second;
      SE3 frame;
      const std::string id = se3::frame_name(m.header.frame_id);
      if (!id.empty() && id != fixed_frame_) {
        try {
          frame = rr::to_se3(tf_buffer_.lookupTransform(fixed_frame_, id, ros::Time(0)).transform);
        } catch (const tf2::TransformException&) {
          continue;
        }
      }
      rr::append_markers(m, frame, out, &marker_meshes_);
    }
    return out;
  }

  void publish_camera_tf(const ros::Time& stamp) {
    const rn::Camera& cam = renderer_->camera();
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = fixed_frame_;
    t.child_frame_id = camera_frame_;
    const geometry_msgs::Pose p = rr::to_pose(SE3(cam.R_wc, cam.eye));
    t.transform.translation.x = p.position.x;
    t.transform.translation.y = p.position.y;
    t.transform.translation.z = p.position.z;
    t.transform.rotation = p.orientation;
    tf_broadcaster_.sendTransform(t);
  }

  // ---------------------------------------------------------------- the frame
  void render_frame() {
    load_model();
    update_poses();
    rn::Camera cam = camera_;
    if (!follow_frame_.empty()) cam = follow_.update(camera_, follow_origin());
    renderer_->set_camera(cam);
    static const std::vector<SE3> kNoBodies;
    renderer_->render(model_ ? poses_ : kNoBodies, convert_markers(), overlay_);
  }

  void on_timer(const ros::WallTimerEvent&) {
    try {
      const ros::Time stamp = ros::Time::now();
      if (model_ && markers_pub_.getNumSubscribers() > 0) {
        markers_pub_.publish(
            rr::rviz_markers(renderer_->items(), item_offsets_inv_, stamp, "se3_sim_robot"));
      }
      if (camera_pub_.getNumSubscribers() == 0) {  // nobody looks: no frame
        load_model();
        return;
      }
      render_frame();
      image_.header.stamp = stamp;
      image_.header.frame_id = camera_frame_;
      renderer_->copy_rgb8(image_.data.data());
      camera_pub_.publish(image_, rr::camera_info(renderer_->camera(), camera_frame_, stamp));
      publish_camera_tf(stamp);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "renderer: frame skipped: %s", e.what());
    }
  }

  ros::NodeHandle nh_, pnh_;
  image_transport::ImageTransport it_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  image_transport::CameraPublisher camera_pub_;
  ros::Publisher markers_pub_;
  ros::Subscriber sim_markers_sub_, camera_sub_, stats_sub_, torque_sub_;
  ros::ServiceServer save_srv_;
  ros::WallTimer timer_;

  double rate_ = 30;
  bool user_camera_ = false, framed_ = false;
  int saved_ = 0;
  std::string fixed_frame_, follow_frame_, save_dir_, camera_frame_, failed_xml_;
  rn::DrawOptions draw_;
  std::unique_ptr<rn::Renderer> renderer_;
  rn::Camera camera_;  ///< the user's camera (before following)
  rr::FollowCamera follow_;
  std::unique_ptr<se3::Model> model_;
  std::vector<SE3> poses_, offsets_inv_, item_offsets_inv_;
  ros::WallTime last_model_try_;
  rr::SimMarkers sim_markers_;
  rr::MarkerMeshes marker_meshes_;
  rn::Overlay overlay_;
  sensor_msgs::Image image_;
};

RendererNode::RendererNode() : impl_(std::make_unique<RendererNodeImpl>()) {}
RendererNode::~RendererNode() = default;

}  // namespace se3_ros
