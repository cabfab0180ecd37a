// renderer_node: draws the robot described by `robot_description`, posed from TF, into
// `renderer/image` (sensor_msgs/Image rgb8, 1280x1024 by default) with `renderer/camera_info`,
// and publishes the same geometry as `renderer/markers` for RViz. A thin adapter over
// se3_sim_render (include/se3_sim/render.h); the camera command convention is documented there.
//
// Parameters (private): ~rate (Hz, 30), ~width (1280), ~height (1024), ~focal_px (1000),
// ~eye [x, y, z] and ~target [x, y, z] (default: framed on the robot), ~fixed_frame ("world"),
// ~save_dir ("/tmp"), ~show_frames (false), ~grid_spacing (0.5), ~camera_frame
// ("renderer_camera_optical", broadcast on TF so others can project into the image).
// Subscribes: robot_description (param, re-read until it parses), /tf, sim_markers,
// renderer/camera_command (geometry_msgs/Twist), sim_stats, torque_command (overlay).
// Service: renderer/save_frame (std_srvs/Empty): the next frame is written as PNG to ~save_dir.
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <ros/ros.h>
#include <se3_sim/JointTorques.h>
#include <se3_sim/SimStats.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/render.h"

namespace {

using se3::Mat3;
using se3::SE3;
using se3::Vec3;
namespace rn = se3::render;

bool finite(double x) {
  return std::isfinite(x);
}

SE3 to_se3(const geometry_msgs::Transform& t) {
  const auto& q = t.rotation;
  const double n = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!(n > 1e-9) || !finite(n) || !finite(t.translation.x) || !finite(t.translation.y) ||
      !finite(t.translation.z))
    return SE3(Mat3::Constant(std::nan("")), Vec3::Constant(std::nan("")));
  return SE3(se3::rotation_from_quaternion(q.x / n, q.y / n, q.z / n, q.w / n),
             Vec3(t.translation.x, t.translation.y, t.translation.z));
}

SE3 to_se3(const geometry_msgs::Pose& p) {
  geometry_msgs::Transform t;
  t.translation.x = p.position.x;
  t.translation.y = p.position.y;
  t.translation.z = p.position.z;
  t.rotation = p.orientation;
  if (p.orientation.x == 0 && p.orientation.y == 0 && p.orientation.z == 0 && p.orientation.w == 0)
    t.rotation.w = 1;  // an unset orientation means identity (as RViz reads it)
  return to_se3(t);
}

geometry_msgs::Pose to_pose(const SE3& f) {
  geometry_msgs::Pose p;
  p.position.x = f.p.x();
  p.position.y = f.p.y();
  p.position.z = f.p.z();
  const Eigen::Vector4d q = se3::quaternion_from_rotation(f.R);
  p.orientation.x = q(0);
  p.orientation.y = q(1);
  p.orientation.z = q(2);
  p.orientation.w = q(3);
  return p;
}

bool read_vec3(ros::NodeHandle& pnh, const std::string& name, Vec3& out) {
  std::vector<double> v;
  if (!pnh.getParam(name, v)) return false;
  if (v.size() != 3 || !finite(v[0]) || !finite(v[1]) || !finite(v[2])) {
    ROS_WARN("renderer: ~%s must be a list of 3 numbers; ignored", name.c_str());
    return false;
  }
  out = Vec3(v[0], v[1], v[2]);
  return true;
}

class RendererNode {
 public:
  RendererNode() : pnh_("~"), tf_listener_(tf_buffer_) {
    pnh_.param("rate", rate_, 30.0);
    if (!(rate_ > 0) || !finite(rate_) || rate_ > 120) {
      ROS_WARN("renderer: ~rate %.3f out of (0, 120]; using 30", rate_);
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
    pnh_.param<std::string>("save_dir", save_dir_, "/tmp");
    pnh_.param<std::string>("camera_frame", camera_frame_, "renderer_camera_optical");
    renderer_ = std::make_unique<rn::Renderer>(cam);
    pnh_.param("show_frames", renderer_->style().frames, false);
    double spacing = 0.5;
    pnh_.param("grid_spacing", spacing, 0.5);
    if (spacing > 0 && finite(spacing)) renderer_->style().grid_spacing = spacing;

    image_.height = cam.height;
    image_.width = cam.width;
    image_.encoding = "rgb8";
    image_.is_bigendian = 0;
    image_.step = cam.width * 3;
    image_.data.resize(size_t(image_.step) * cam.height);

    image_pub_ = nh_.advertise<sensor_msgs::Image>("renderer/image", 2);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("renderer/camera_info", 2);
    markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("renderer/markers", 2);
    sim_markers_sub_ = nh_.subscribe("sim_markers", 10, &RendererNode::on_sim_markers, this);
    camera_sub_ = nh_.subscribe("renderer/camera_command", 20, &RendererNode::on_camera, this);
    stats_sub_ = nh_.subscribe("sim_stats", 5, &RendererNode::on_stats, this);
    torque_sub_ = nh_.subscribe("torque_command", 5, &RendererNode::on_torque, this);
    save_srv_ = nh_.advertiseService("renderer/save_frame", &RendererNode::on_save, this);
    timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / rate_), &RendererNode::on_timer, this);
    ROS_INFO("renderer: %dx%d at %.1f Hz in frame '%s'", cam.width, cam.height, rate_,
             fixed_frame_.c_str());
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
      auto m = std::make_unique<se3::Model>(se3::model_from_urdf_string(xml, opt));
      renderer_->set_model(*m);
      poses_.assign(m->parent.size(),
                    SE3(Mat3::Constant(std::nan("")), Vec3::Constant(std::nan(""))));
      offsets_inv_.assign(m->parent.size(), SE3());
      for (size_t i = 0; i < m->body_name.size() && i < offsets_inv_.size(); ++i) {
        const int li = m->link_index(m->body_name[i]);
        if (li >= 0) offsets_inv_[i] = m->links[li].offset.inverse();
      }
      model_ = std::move(m);
      ROS_INFO("renderer: model '%s' with %d bodies, %zu drawn primitives", model_->name.c_str(),
               int(model_->parent.size()), renderer_->items().size());
    } catch (const std::exception& e) {
      failed_xml_ = xml;
      ROS_ERROR("renderer: robot_description rejected: %s", e.what());
    }
  }

  void update_poses() {
    if (!model_) return;
    bool any_new = false;
    for (size_t i = 0; i < poses_.size() && i < model_->body_name.size(); ++i) {
      try {
        const auto t = tf_buffer_.lookupTransform(fixed_frame_, model_->body_name[i], ros::Time(0));
        const SE3 link = to_se3(t.transform);
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
      rn::Camera cam = renderer_->camera();
      rn::frame_bodies(*model_, poses_, cam, convert_markers());
      renderer_->set_camera(cam);
      framed_ = true;
    }
  }

  // ---------------------------------------------------------------- inputs
  void on_sim_markers(const visualization_msgs::MarkerArray::ConstPtr& msg) {
    for (const auto& m : msg->markers) {
      if (m.action == visualization_msgs::Marker::DELETEALL) {
        sim_markers_.clear();
        continue;
      }
      const auto key = std::make_pair(m.ns, m.id);
      if (m.action == visualization_msgs::Marker::DELETE) {
        sim_markers_.erase(key);
        continue;
      }
      // A box that is new (e.g. the scene's satellite bus) is solid geometry: frame it too.
      if (m.type == visualization_msgs::Marker::CUBE && !sim_markers_.count(key)) framed_ = false;
      sim_markers_[key] = m;
    }
  }

  void on_camera(const geometry_msgs::Twist::ConstPtr& msg) {
    rn::Camera cam = renderer_->camera();
    const double zoom_delta = finite(msg->linear.x) ? msg->linear.x : 0.0;
    const double zoom = std::min(10.0, std::max(0.1, 1.0 - zoom_delta));
    const Vec3 right = cam.R_wc.col(0);
    Vec3 pan = Vec3::Zero();
    if (finite(msg->linear.y)) pan += msg->linear.y * right;
    if (finite(msg->linear.z)) pan += msg->linear.z * Vec3::UnitZ();
    if (pan.allFinite() && pan.norm() < 100) {
      cam.eye += pan;
      cam.target += pan;
    }
    cam.orbit(finite(msg->angular.z) ? msg->angular.z : 0.0,
              finite(msg->angular.y) ? msg->angular.y : 0.0, zoom);
    renderer_->set_camera(cam);
    framed_ = true;  // the user steers now
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
    for (size_t i = 0; i < msg->name.size() && i < msg->effort.size(); ++i) {
      if (finite(msg->effort[i]) && std::abs(msg->effort[i]) >= std::abs(best) &&
          (msg->effort[i] != 0 || joint.empty())) {
        best = msg->effort[i];
        joint = msg->name[i];
      }
    }
    overlay_.joint = joint;
    overlay_.torque = joint.empty() ? std::nan("") : best;
  }

  bool on_save(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
    save_next_ = true;
    return true;
  }

  // ---------------------------------------------------------------- markers
  std::vector<rn::Marker> convert_markers() {
    std::vector<rn::Marker> out;
    for (const auto& kv : sim_markers_) {
      const visualization_msgs::Marker& m = kv.second;
      SE3 frame;
      if (!m.header.frame_id.empty() && m.header.frame_id != fixed_frame_) {
        try {
          frame = to_se3(
              tf_buffer_.lookupTransform(fixed_frame_, m.header.frame_id, ros::Time(0)).transform);
        } catch (const tf2::TransformException&) {
          continue;
        }
      }
      const SE3 pose = frame * to_se3(m.pose);
      if (!pose.R.allFinite() || !pose.p.allFinite()) continue;
      const Eigen::Vector3d color(m.color.r, m.color.g, m.color.b);
      auto pt = [&](const geometry_msgs::Point& p) { return pose.act(Vec3(p.x, p.y, p.z)); };
      rn::Marker r;
      r.color = color;
      switch (m.type) {
        case visualization_msgs::Marker::SPHERE:
          r.type = rn::Marker::Type::Sphere;
          r.a = pose.p;
          r.size = m.scale.x;
          out.push_back(r);
          break;
        case visualization_msgs::Marker::CUBE:
          r.type = rn::Marker::Type::Box;
          r.a = pose.p;
          r.R = pose.R;
          r.size3 = Vec3(m.scale.x, m.scale.y, m.scale.z);
          out.push_back(r);
          break;
        case visualization_msgs::Marker::ARROW:
          r.type = rn::Marker::Type::Arrow;
          if (m.points.size() >= 2) {
            r.a = pt(m.points[0]);
            r.b = pt(m.points[1]);
            r.size = m.scale.x;
          } else {
            r.a = pose.p;
            r.b = pose.act(Vec3(m.scale.x, 0, 0));
            r.size = m.scale.y;
          }
          out.push_back(r);
          break;
        case visualization_msgs::Marker::POINTS:
        case visualization_msgs::Marker::SPHERE_LIST:
          for (const auto& p : m.points) {
            r.type = m.type == visualization_msgs::Marker::POINTS ? rn::Marker::Type::Point
                                                                  : rn::Marker::Type::Sphere;
            r.a = pt(p);
            r.size = m.type == visualization_msgs::Marker::POINTS ? 6.0 : m.scale.x;
            out.push_back(r);
          }
          break;
        case visualization_msgs::Marker::LINE_STRIP:
        case visualization_msgs::Marker::LINE_LIST: {
          const bool strip = m.type == visualization_msgs::Marker::LINE_STRIP;
          for (size_t i = 0; i + 1 < m.points.size(); i += strip ? 1 : 2) {
            r.type = rn::Marker::Type::Line;
            r.a = pt(m.points[i]);
            r.b = pt(m.points[i + 1]);
            r.size = 2.0;
            out.push_back(r);
          }
          break;
        }
        default:
          break;
      }
    }
    return out;
  }

  void publish_rviz_markers(const ros::Time& stamp) {
    if (!model_ || markers_pub_.getNumSubscribers() == 0) return;
    visualization_msgs::MarkerArray arr;
    int id = 0;
    for (const rn::DrawItem& it : renderer_->items()) {
      visualization_msgs::Marker m;
      m.header.stamp = stamp;
      m.header.frame_id = fixed_frame_;
      m.ns = "se3_sim_robot";
      m.id = id++;
      const SE3 pose = it.body < int(poses_.size()) ? poses_[it.body] * it.local : SE3();
      if (!pose.R.allFinite() || !pose.p.allFinite()) {
        m.action = visualization_msgs::Marker::DELETE;
        arr.markers.push_back(m);
        continue;
      }
      m.action = visualization_msgs::Marker::ADD;
      m.type = it.shape == rn::DrawItem::Shape::Box        ? visualization_msgs::Marker::CUBE
               : it.shape == rn::DrawItem::Shape::Cylinder ? visualization_msgs::Marker::CYLINDER
                                                           : visualization_msgs::Marker::SPHERE;
      m.pose = to_pose(pose);
      m.scale.x = it.size.x();
      m.scale.y = it.size.y();
      m.scale.z = it.size.z();
      m.color.r = float(it.color.x());
      m.color.g = float(it.color.y());
      m.color.b = float(it.color.z());
      m.color.a = 1.0f;
      arr.markers.push_back(m);
    }
    markers_pub_.publish(arr);
  }

  void publish_camera(const ros::Time& stamp) {
    const rn::Camera& cam = renderer_->camera();
    sensor_msgs::CameraInfo info;
    info.header.stamp = stamp;
    info.header.frame_id = camera_frame_;
    info.width = cam.width;
    info.height = cam.height;
    info.distortion_model = "plumb_bob";
    info.D.assign(5, 0.0);
    // ROS puts the centre of the top-left pixel at (0, 0); ours is at (0.5, 0.5).
    const double cx = cam.cx() - 0.5, cy = cam.cy() - 0.5;
    info.K = {cam.focal_px, 0, cx, 0, cam.focal_px, cy, 0, 0, 1};
    info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    info.P = {cam.focal_px, 0, cx, 0, 0, cam.focal_px, cy, 0, 0, 0, 1, 0};
    info_pub_.publish(info);

    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = fixed_frame_;
    t.child_frame_id = camera_frame_;
    const geometry_msgs::Pose p = to_pose(SE3(cam.R_wc, cam.eye));
    t.transform.translation.x = p.position.x;
    t.transform.translation.y = p.position.y;
    t.transform.translation.z = p.position.z;
    t.transform.rotation = p.orientation;
    tf_broadcaster_.sendTransform(t);
  }

  // ---------------------------------------------------------------- the frame
  void on_timer(const ros::WallTimerEvent&) {
    try {
      load_model();
      update_poses();
      const std::vector<rn::Marker> markers = convert_markers();
      static const std::vector<SE3> kNoBodies;
      renderer_->render(model_ ? poses_ : kNoBodies, markers, overlay_);
      const ros::Time stamp = ros::Time::now();
      image_.header.stamp = stamp;
      image_.header.frame_id = camera_frame_;
      renderer_->framebuffer().copy_rgb8(image_.data.data());
      image_pub_.publish(image_);
      publish_camera(stamp);
      publish_rviz_markers(stamp);
      if (save_next_) {
        save_next_ = false;
        char name[64];
        std::snprintf(name, sizeof name, "/se3_sim_frame_%06d.png", saved_++);
        std::string err;
        if (renderer_->write_png(save_dir_ + name, &err))
          ROS_INFO("renderer: saved %s%s", save_dir_.c_str(), name);
        else
          ROS_ERROR("renderer: %s", err.c_str());
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "renderer: frame skipped: %s", e.what());
    }
  }

  ros::NodeHandle nh_, pnh_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Publisher image_pub_, info_pub_, markers_pub_;
  ros::Subscriber sim_markers_sub_, camera_sub_, stats_sub_, torque_sub_;
  ros::ServiceServer save_srv_;
  ros::WallTimer timer_;

  double rate_ = 30;
  bool user_camera_ = false, framed_ = false, save_next_ = false;
  int saved_ = 0;
  std::string fixed_frame_, save_dir_, camera_frame_, failed_xml_;
  std::unique_ptr<rn::Renderer> renderer_;
  std::unique_ptr<se3::Model> model_;
  std::vector<SE3> poses_, offsets_inv_;
  ros::WallTime last_model_try_;
  std::map<std::pair<std::string, int>, visualization_msgs::Marker> sim_markers_;
  rn::Overlay overlay_;
  sensor_msgs::Image image_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "renderer");
  RendererNode node;
  ros::spin();
  return 0;
}
