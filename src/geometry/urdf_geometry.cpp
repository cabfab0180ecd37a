// GeometryModel from URDF: the visual and collision elements of every link, placed on the
// Model's bodies through model.links, with materials, meshes loaded through the resolver and
// stand-ins (with one warning each) for meshes that cannot be loaded.
#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <utility>

#include "se3_sim/geometry/geometry.h"

namespace se3 {
namespace {

namespace fs = std::filesystem;

// A frame whose z axis runs from a to b, centred between them.
SE3 segment_frame(const Vec3& a, const Vec3& b) {
  const Vec3 z = (b - a).normalized();
  const Vec3 helper = std::abs(z.z()) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
  const Vec3 x = helper.cross(z).normalized();
  Mat3 R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return SE3(R, 0.5 * (a + b));
}

struct GeometryBuilder {
  const Model& model;
  const urdf::ModelInterface& urdf;
  const GeometryOptions& opt;
  GeometryModel g;
  std::map<std::string, int> names;  // per list: link -> count
  double stand_in_radius = 0.03;

  std::string resolve(const std::string& uri, std::string* err) const {
    if (opt.resolver) return opt.resolver(uri, err);
    return resolve_resource(uri, opt.paths, err);
  }

  // Fills o.shape from a URDF geometry; false (and a reason) for a mesh that did not load.
  bool convert(const urdf::GeometrySharedPtr& geo, GeometryObject& o, std::string* why) {
    switch (geo->type) {
      case urdf::Geometry::BOX: {
        const auto b = std::static_pointer_cast<urdf::Box>(geo);
        o.shape = make_box(Vec3(b->dim.x, b->dim.y, b->dim.z));
        return true;
      }
      case urdf::Geometry::SPHERE:
        o.shape = make_sphere(std::static_pointer_cast<urdf::Sphere>(geo)->radius);
        return true;
      case urdf::Geometry::CYLINDER: {
        const auto c = std::static_pointer_cast<urdf::Cylinder>(geo);
        o.shape = make_cylinder(c->radius, c->length);
        return true;
      }
      case urdf::Geometry::MESH: {
        const auto m = std::static_pointer_cast<urdf::Mesh>(geo);
        o.shape = Shape();
        o.shape.type = ShapeType::Mesh;
        o.shape.resource = m->filename;
        o.shape.scale = Vec3(m->scale.x, m->scale.y, m->scale.z);
        if (!opt.load_meshes) {
          *why = "meshes not loaded (load_meshes = false)";
          return false;
        }
        if (!o.shape.scale.allFinite()) {
          *why = "non-finite mesh scale";
          return false;
        }
        std::string err;
        o.shape.path = resolve(m->filename, &err);
        if (o.shape.path.empty()) {
          *why = err.empty() ? std::string("cannot resolve it") : err;
          return false;
        }
        o.shape.mesh = load_mesh(o.shape.path, &err, opt.limits);
        if (!o.shape.mesh) {
          *why = err.compare(0, o.shape.path.size() + 2, "'" + o.shape.path + "'") == 0
                     ? err
                     : "'" + o.shape.path + "': " + err;
          return false;
        }
        return true;
      }
    }
    *why = "unknown geometry type";
    return false;
  }

  std::string next_name(std::map<std::string, int>& count, const std::string& link) {
    return link + "_" + std::to_string(count[link]++);
  }

  template <class Element>
  void add(const std::shared_ptr<Element>& e, const std::string& link, int body, const SE3& O,
           bool visual, std::map<std::string, int>& count) {
    if (!e || !e->geometry) return;
    GeometryObject o;
    o.link = link;
    o.body = body;
    o.placement = O * se3_from_urdf(e->origin);
    std::string why;
    const bool ok = convert(e->geometry, o, &why);
    if constexpr (std::is_same_v<Element, urdf::Visual>) {
      const urdf::MaterialSharedPtr& mat = e->material;
      if (mat) {
        o.material.name = mat->name;
        const urdf::Color& c = mat->color;
        // urdfdom leaves (0, 0, 0, 1) for a material given only by a texture.
        const bool texture_only =
            !mat->texture_filename.empty() && c.r == 0 && c.g == 0 && c.b == 0 && c.a == 1;
        const Vec4f rgba(c.r, c.g, c.b, c.a);
        if (!texture_only && rgba.allFinite()) {
          o.material.rgba = rgba.cwiseMax(0.0f).cwiseMin(1.0f);
          o.material.has_color = true;
        }
      }
    }
    if (ok && o.shape.mesh && !o.shape.mesh->warning.empty()) {
      g.warnings.push_back(std::string("link '") + link +
                           "': " + (visual ? "visual" : "collision") + " mesh '" +
                           o.shape.resource + "': " + o.shape.mesh->warning);
    }
    if (!ok) {
      o.stand_in = true;
      o.warning = std::string("link '") + link + "': " + (visual ? "visual" : "collision") +
                  " mesh '" + o.shape.resource + "' not loaded: " + why;
      if (opt.load_meshes)
        g.warnings.push_back(o.warning +
                             (visual ? "; drawn as a stand-in" : "; skipped by collision"));
    }
    o.name = next_name(count, link);
    (visual ? g.visuals : g.collisions).push_back(o);
  }

  // Replaces every visual that did not load by its stand-in: the link's collision shapes that
  // are usable, else capsules from the link frame to the joints of its child links, else a
  // ball at the visual's origin.
  void stand_ins() {
    std::vector<GeometryObject> out;
    std::map<std::string, bool> done;  // link -> stand-in already made
    for (GeometryObject& v : g.visuals) {
      if (!v.stand_in) {
        out.push_back(v);
        continue;
      }
      if (done[v.link]) continue;  // one stand-in per link (its warnings are all kept)
      done[v.link] = true;
      bool found = false;
      for (const GeometryObject& c : g.collisions) {
        if (c.link != v.link || c.stand_in) continue;
        GeometryObject s = c;
        s.stand_in = true;
        s.warning = v.warning;
        s.material = v.material;
        s.name = v.name + "_stand_in";
        out.push_back(s);
        found = true;
      }
      if (found) continue;
      const urdf::LinkConstSharedPtr link = find_link(v.link);
      const int li = model.link_index(v.link);
      const SE3 O = li >= 0 ? model.links[li].offset : SE3();
      if (link) {
        for (const auto& j : link->child_joints) {
          const Vec3 a = O.p, b = O.act(se3_from_urdf(j->parent_to_joint_origin_transform).p);
          const double len = (b - a).norm();
          if (!(len > 1e-4) || !std::isfinite(len)) continue;
          GeometryObject s = v;
          s.shape = make_capsule(stand_in_radius, len);
          s.placement = segment_frame(a, b);
          s.name = v.name + "_stand_in_" + j->name;
          out.push_back(s);
          found = true;
        }
      }
      if (found) continue;
      GeometryObject s = v;
      s.shape = make_sphere(stand_in_radius);
      s.name = v.name + "_stand_in";
      out.push_back(s);
    }
    g.visuals = std::move(out);
  }

  urdf::LinkConstSharedPtr find_link(const std::string& frame) const {
    urdf::LinkConstSharedPtr l = urdf.getLink(frame);
    if (!l) l = urdf.getLink("/" + frame);
    return l;
  }
};

}  // namespace

GeometryModel geometry_from_urdf(const Model& model, const UrdfDocument& doc, GeometryOptions opt) {
  if (!doc.urdf) throw ModelError("URDF: no document");
  if (opt.paths.base_dir.empty() && !doc.file.empty()) {
    opt.paths.base_dir = fs::absolute(fs::path(doc.file)).parent_path().string();
  }
  GeometryBuilder b{model, *doc.urdf, opt, {}, {}};
  // Stand-in capsules scale with the robot: a fifth of its typical joint spacing.
  double sum = 0;
  int cnt = 0;
  for (int i = 1; i <= model.n && i < int(model.X_tree.size()); ++i) {
    const double l = model.X_tree[i].p.norm();
    if (l > 1e-4 && std::isfinite(l)) sum += l, ++cnt;
  }
  b.stand_in_radius = std::clamp(cnt ? 0.2 * sum / cnt : 0.03, 0.01, 0.05);

  std::map<std::string, int> vcount, ccount;
  for (const LinkFrame& lf : model.links) {
    const urdf::LinkConstSharedPtr link = b.find_link(lf.name);
    if (!link) continue;
    if (!link->collision_array.empty()) {
      for (const auto& c : link->collision_array)
        b.add(c, lf.name, lf.body, lf.offset, false, ccount);
    } else {
      b.add(link->collision, lf.name, lf.body, lf.offset, false, ccount);
    }
    if (!link->visual_array.empty()) {
      for (const auto& v : link->visual_array) b.add(v, lf.name, lf.body, lf.offset, true, vcount);
    } else {
      b.add(link->visual, lf.name, lf.body, lf.offset, true, vcount);
    }
  }
  b.stand_ins();
  // A <gazebo reference="LINK"><material>Gazebo/NAME</material> is what Gazebo draws: it
  // replaces the URDF's colour of that link's visuals.
  for (GeometryObject& o : b.g.visuals) {
    const GazeboLink* gl = doc.gazebo.link(o.link);
    std::array<float, 4> c;
    if (!gl || gl->material.empty() || !gazebo_material_rgba(gl->material, c)) continue;
    o.material.name = gl->material;
    o.material.rgba = Vec4f(c[0], c[1], c[2], c[3]);
    o.material.has_color = true;
  }
  return std::move(b.g);
}

GeometryModel geometry_from_urdf_string(const Model& model, const std::string& xml,
                                        const GeometryOptions& opt) {
  return geometry_from_urdf(model, parse_urdf_document(xml), opt);
}

GeometryModel geometry_from_urdf_file(const Model& model, const std::string& path,
                                      GeometryOptions opt) {
  return geometry_from_urdf(model, read_urdf_document(path), std::move(opt));
}

}  // namespace se3
