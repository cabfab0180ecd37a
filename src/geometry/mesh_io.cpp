// Mesh files through assimp: STL, Collada, OBJ (+ .mtl) and the rest assimp reads, into
// TriangleMesh; the load cache (file loads in a child process, see isolated()); Collada's unit
// and up axis the way RViz reads them.
#include <assimp/MemoryIOWrapper.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"

namespace se3 {
namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string extension_of(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  if (!e.empty() && e[0] == '.') e.erase(0, 1);
  return lower(e);
}

// Binary STL's header against its size: a truncated file or an absurd triangle count gets its
// own reason before assimp sees it. ASCII STL (starts with "solid" and is not exactly the size
// a binary file of its count would be) passes.
bool check_stl(const unsigned char* d, std::size_t size, const MeshLimits& limits,
               std::string* error) {
  const bool solid = size >= 5 && std::memcmp(d, "solid", 5) == 0;
  if (size < 84) {
    if (solid) return true;
    if (error) {
      *error =
          "truncated STL: " + std::to_string(size) + " bytes (a binary STL has an 84-byte header)";
    }
    return false;
  }
  const uint64_t n =
      uint64_t(d[80]) | uint64_t(d[81]) << 8 | uint64_t(d[82]) << 16 | uint64_t(d[83]) << 24;
  const uint64_t need = 84 + 50 * n;
  if (solid && need != size) return true;  // ASCII
  if (n > limits.max_triangles) {
    if (error) {
      *error = "binary STL claims " + std::to_string(n) + " triangles (more than the limit of " +
               std::to_string(limits.max_triangles) + ")";
    }
    return false;
  }
  if (need > size) {
    if (error) {
      *error = "truncated binary STL: its header claims " + std::to_string(n) + " triangles (" +
               std::to_string(need) + " bytes), the file has " + std::to_string(size);
    }
    return false;
  }
  if (n == 0) {
    if (error) *error = "the STL holds no triangles";
    return false;
  }
  return true;
}

// Import flags of the first pass: validated, triangles only (points and lines dropped).
unsigned configure(Assimp::Importer& imp) {
  imp.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // A file without meshes is an error here, not a skeleton drawn as a stand-in by assimp.
  imp.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);
  // Smooth shading across edges below 60 degrees; sharper creases keep one normal a side.
  imp.SetPropertyFloat(AI_CONFIG_PP_GSN_MAX_SMOOTHING_ANGLE, 60.0f);
  return aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_SortByPType;
}

// ---- What assimp may read besides the bytes it is given
//
// An importer opens other files through its IOSystem: an OBJ its .mtl (`mtllib` names any
// path), and a file read from memory is wrapped around the importer's IOSystem too. This one
// reads only regular files (read_file, limits.h: never a FIFO or a device), at most the mesh
// byte limit, and only inside `root` (the folder of the mesh and below; "" refuses every
// file). What it refused is kept for the mesh's warning.
class GuardedIO : public Assimp::IOSystem {
 public:
  GuardedIO(const std::string& root, std::size_t max_bytes) : max_bytes_(max_bytes) {
    std::error_code ec;
    if (!root.empty()) root_ = fs::weakly_canonical(root, ec);
    if (ec) root_.clear();
  }
  bool Exists(const char* file) const override {
    return file && inside(file) && not_a_regular_file(file).empty();
  }
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (!file) return nullptr;
    if (mode && (std::strchr(mode, 'w') || std::strchr(mode, 'a') || std::strchr(mode, '+'))) {
      return nullptr;  // a loader writes nothing
    }
    if (!inside(file)) {
      refuse(std::string("'") + file + "' is outside the mesh's folder");
      return nullptr;
    }
    std::string text, why;
    if (!read_file(file, text, &why, max_bytes_)) {
      refuse(std::string("'") + file + "': " + why);
      return nullptr;
    }
    auto* bytes = new uint8_t[text.size() + 1];
    std::memcpy(bytes, text.data(), text.size());
    return new Assimp::MemoryIOStream(bytes, text.size(), true);
  }
  void Close(Assimp::IOStream* stream) override { delete stream; }
  const std::vector<std::string>& refused() const { return refused_; }

 private:
  bool inside(const char* file) const {
    if (root_.empty()) return false;
    std::error_code ec;
    const fs::path p = fs::weakly_canonical(file, ec);
    if (ec) return false;
    const auto r = std::mismatch(root_.begin(), root_.end(), p.begin(), p.end());
    return r.first == root_.end();
  }
  void refuse(const std::string& what) {
    if (refused_.size() < 4 &&
        std::find(refused_.begin(), refused_.end(), what) == refused_.end()) {
      refused_.push_back(what);
    }
  }
  fs::path root_;
  std::size_t max_bytes_;
  std::vector<std::string> refused_;
};

// Appends one clause to a mesh's one-line warning.
void add_warning(std::string& warning, const std::string& what) {
  if (what.empty()) return;
  warning += (warning.empty() ? "" : "; ") + what;
}

// A vertex position as a hashable key (bit patterns: -0 and 0 differ, which only splits).
struct PosKey {
  uint32_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PosHash {
  std::size_t operator()(const PosKey& k) const {
    return (std::size_t(k.x) * 73856093u) ^ (std::size_t(k.y) * 19349663u) ^
           (std::size_t(k.z) * 83492791u);
  }
};
PosKey pos_key(const aiVector3D& v) {
  PosKey k;
  std::memcpy(&k.x, &v.x, 4);
  std::memcpy(&k.y, &v.y, 4);
  std::memcpy(&k.z, &v.z, 4);
  return k;
}

// A face as its three position ids, rotated to start at the smallest (the same face in the
// same winding has one key; its reverse, a back face, another).
struct FaceKey {
  uint32_t a, b, c;
  bool operator==(const FaceKey& o) const { return a == o.a && b == o.b && c == o.c; }
};
struct FaceHash {
  std::size_t operator()(const FaceKey& k) const {
    return (std::size_t(k.a) * 2654435761u) ^ (std::size_t(k.b) * 40503u) ^ std::size_t(k.c);
  }
};

// Drops the triangles of m that repeat an earlier one (same positions, same winding) or are
// degenerate (two corners at one position), and the vertices no kept face uses; in linear
// time. Meshes with bones or animation keep their vertices (their weights index them).
// Returns the numbers dropped.
std::pair<std::size_t, std::size_t> drop_repeated_faces(aiMesh* m) {
  if (!m || !m->mVertices || !m->mFaces || m->mNumBones > 0 || m->mNumAnimMeshes > 0) return {};
  std::unordered_map<PosKey, uint32_t, PosHash> ids;
  ids.reserve(m->mNumVertices);
  std::vector<uint32_t> id(m->mNumVertices);
  for (unsigned v = 0; v < m->mNumVertices; ++v) {
    id[v] = ids.emplace(pos_key(m->mVertices[v]), uint32_t(ids.size())).first->second;
  }
  std::unordered_map<FaceKey, char, FaceHash> seen;
  std::size_t duplicate = 0, degenerate = 0;
  unsigned kept = 0;
  for (unsigned f = 0; f < m->mNumFaces; ++f) {
    aiFace& face = m->mFaces[f];
    bool drop = false;
    if (face.mNumIndices == 3 && face.mIndices[0] < m->mNumVertices &&
        face.mIndices[1] < m->mNumVertices && face.mIndices[2] < m->mNumVertices) {
      uint32_t a = id[face.mIndices[0]], b = id[face.mIndices[1]], c = id[face.mIndices[2]];
      if (a == b || b == c || a == c) {
        drop = true;
        ++degenerate;
      } else {
        while (a > b || a > c) {
          const uint32_t t = a;
          a = b, b = c, c = t;
        }
        if (!seen.emplace(FaceKey{a, b, c}, 0).second) {
          drop = true;
          ++duplicate;
        }
      }
    }
    if (drop) {
      delete[] face.mIndices;
      face.mIndices = nullptr;
      face.mNumIndices = 0;
      continue;
    }
    if (kept != f) {
      std::swap(m->mFaces[kept].mIndices, face.mIndices);
      std::swap(m->mFaces[kept].mNumIndices, face.mNumIndices);
    }
    ++kept;
  }
  if (duplicate + degenerate == 0) return {};
  m->mNumFaces = kept;
  // Keep only the vertices kept faces use, in their order.
  std::vector<uint32_t> remap(m->mNumVertices, UINT32_MAX);
  unsigned nv = 0;
  for (unsigned f = 0; f < kept; ++f) {
    aiFace& face = m->mFaces[f];
    for (unsigned k = 0; k < face.mNumIndices; ++k) {
      const unsigned v = face.mIndices[k];
      if (v >= m->mNumVertices) continue;
      if (remap[v] == UINT32_MAX) remap[v] = nv++;
      face.mIndices[k] = remap[v];
    }
  }
  auto compact = [&](auto*& array) {
    if (!array) return;
    using T = std::remove_pointer_t<std::remove_reference_t<decltype(array)>>;
    T* out = new T[std::max(1u, nv)];
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      if (remap[v] != UINT32_MAX) out[remap[v]] = array[v];
    }
    delete[] array;
    array = out;
  };
  compact(m->mVertices);
  compact(m->mNormals);
  compact(m->mTangents);
  compact(m->mBitangents);
  for (auto& c : m->mColors) compact(c);
  for (auto& t : m->mTextureCoords) compact(t);
  m->mNumVertices = nv;
  return {duplicate, degenerate};
}

// What assimp's smoothing and joining cost (they look, for each vertex, at every vertex at its
// position): the sum over positions of the count squared.
std::size_t smoothing_work(const aiMesh* m) {
  if (!m || !m->mVertices) return 0;
  std::unordered_map<PosKey, std::size_t, PosHash> count;
  count.reserve(m->mNumVertices);
  std::size_t work = 0;
  for (unsigned v = 0; v < m->mNumVertices; ++v) {
    const std::size_t c = ++count[pos_key(m->mVertices[v])];
    work += 2 * c - 1;  // c^2 - (c - 1)^2
  }
  return work;
}

// Per-vertex normals summed from the area-weighted normals of the faces using each vertex, in
// linear time: the stand-in for assimp's smoothing when its work is beyond the bound (on a
// mesh whose vertices are one per face corner, as OBJ and STL import them, each face is flat).
void face_normals(aiMesh* m) {
  delete[] m->mNormals;
  m->mNormals = new aiVector3D[std::max(1u, m->mNumVertices)]();
  for (unsigned f = 0; f < m->mNumFaces; ++f) {
    const aiFace& face = m->mFaces[f];
    if (face.mNumIndices != 3) continue;
    const unsigned a = face.mIndices[0], b = face.mIndices[1], c = face.mIndices[2];
    if (a >= m->mNumVertices || b >= m->mNumVertices || c >= m->mNumVertices) continue;
    const aiVector3D n = (m->mVertices[b] - m->mVertices[a]) ^ (m->mVertices[c] - m->mVertices[a]);
    m->mNormals[a] += n;
    m->mNormals[b] += n;
    m->mNormals[c] += n;
  }
}

// Second pass: meshes without normals, or with one normal a face (every STL, and CAD exports
// such as the Panda's Collada files), get smooth per-vertex normals; then vertices that are
// equal in everything are joined (a flat-shaded file has three vertices a triangle).
// Smoothing and joining are quadratic in the vertices that share one position (30,000 copies
// of one triangle, a fan of 30,000 triangles): when their work is beyond
// limits.max_smoothing_work, repeated and degenerate faces are dropped first, and if that is
// not enough each face keeps its own normal. Returns what it did, for the mesh's warning (""
// when nothing).
std::string smooth_and_join(Assimp::Importer& imp, const MeshLimits& limits) {
  aiScene* scene = const_cast<aiScene*>(imp.GetScene());
  if (!scene) return "";
  std::string warning;
  std::size_t work = 0;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) work += smoothing_work(scene->mMeshes[k]);
  if (work > limits.max_smoothing_work) {
    // Only then (an ordinary mesh is left exactly as assimp reads it): repeated and degenerate
    // faces out, and the work counted again.
    std::size_t duplicate = 0, degenerate = 0;
    work = 0;
    for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
      const auto dropped = drop_repeated_faces(scene->mMeshes[k]);
      duplicate += dropped.first;
      degenerate += dropped.second;
      work += smoothing_work(scene->mMeshes[k]);
    }
    if (duplicate) add_warning(warning, std::to_string(duplicate) + " duplicate faces dropped");
    if (degenerate) {
      add_warning(warning, std::to_string(degenerate) + " degenerate faces dropped");
    }
  }
  const bool bounded = work > limits.max_smoothing_work;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    aiMesh* m = scene->mMeshes[k];
    if (!m || !m->mNormals) {
      if (m && bounded) face_normals(m);
      continue;
    }
    unsigned flat = 0, faces = 0;
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices != 3) continue;
      ++faces;
      const aiVector3D& a = m->mNormals[face.mIndices[0]];
      const aiVector3D& b = m->mNormals[face.mIndices[1]];
      const aiVector3D& c = m->mNormals[face.mIndices[2]];
      if ((a - b).SquareLength() < 1e-8f && (a - c).SquareLength() < 1e-8f) ++flat;
    }
    if (faces && flat >= faces - faces / 10) {
      delete[] m->mNormals;
      m->mNormals = nullptr;
      if (bounded) face_normals(m);
    }
  }
  if (bounded) {
    add_warning(warning, "normals not smoothed: " + std::to_string(work) +
                             " vertex pairs at shared positions, more than the " +
                             std::to_string(limits.max_smoothing_work) +
                             " of MeshLimits::max_smoothing_work (faces drawn flat)");
    return warning;
  }
  imp.ApplyPostProcessing(aiProcess_GenSmoothNormals | aiProcess_JoinIdenticalVertices);
  return warning;
}

bool finite3(const aiVector3D& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// The scene's triangles in the file's model frame, as RViz builds them: every node's meshes
// through the node's transform chain; of the root node's own transform only translation and
// scale (Collada's <unit>) are kept, its rotation (assimp's up-axis conversion) dropped.
std::shared_ptr<TriangleMesh> mesh_from_scene(const aiScene* scene, const std::string& hint,
                                              const MeshLimits& limits, std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return std::shared_ptr<TriangleMesh>();
  };
  if (!scene || !scene->mRootNode) return fail("no scene");
  aiVector3D scaling, position;
  aiQuaternion rotation;
  scene->mRootNode->mTransformation.Decompose(scaling, rotation, position);
  aiMatrix4x4 T, S;
  aiMatrix4x4::Translation(position, T);
  aiMatrix4x4::Scaling(scaling, S);
  const aiMatrix4x4 root = T * S;

  // First pass: count (instances included), so limits hold before anything is allocated.
  struct Item {
    const aiMesh* mesh;
    aiMatrix4x4 world;
  };
  std::vector<Item> items;
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{{scene->mRootNode, root}};
  uint64_t triangles = 0, vertices = 0;
  int nodes = 0;
  while (!stack.empty()) {
    const auto [node, world] = stack.back();
    stack.pop_back();
    if (++nodes > 1000000) return fail("more than a million scene nodes");
    for (unsigned k = 0; k < node->mNumMeshes; ++k) {
      if (node->mMeshes[k] >= scene->mNumMeshes) return fail("node names a missing mesh");
      const aiMesh* m = scene->mMeshes[node->mMeshes[k]];
      if (!m || !(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || !m->mVertices) continue;
      items.push_back({m, world});
      triangles += m->mNumFaces;
      vertices += m->mNumVertices;
      if (triangles > limits.max_triangles) {
        return fail("more than " + std::to_string(limits.max_triangles) + " triangles");
      }
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) {
      if (node->mChildren[c])
        stack.emplace_back(node->mChildren[c], world * node->mChildren[c]->mTransformation);
    }
  }
  if (triangles == 0) return fail("the file holds no triangles");
  if (vertices > 3 * limits.max_triangles) return fail("too many vertices");

  auto out = std::make_shared<TriangleMesh>();
  out->positions.reserve(vertices);
  out->normals.reserve(vertices);
  out->indices.reserve(3 * triangles);
  bool any_colors = false;
  for (const Item& it : items) any_colors = any_colors || it.mesh->HasVertexColors(0);
  const bool stl = hint == "stl" || hint == "stlb";
  for (const Item& it : items) {
    const aiMesh* m = it.mesh;
    const uint32_t base = uint32_t(out->positions.size());
    aiMatrix3x3 nrm(it.world);
    const float det = nrm.Determinant();
    if (!(std::abs(det) > 0) || !std::isfinite(det)) continue;  // a node that flattens
    nrm.Inverse().Transpose();
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      const aiVector3D p = it.world * m->mVertices[v];
      if (!finite3(p)) return fail("non-finite vertex coordinates");
      out->positions.emplace_back(p.x, p.y, p.z);
      aiVector3D n = m->mNormals ? nrm * m->mNormals[v] : aiVector3D(0, 0, 1);
      const float len = n.Length();
      n = len > 0 && std::isfinite(len) ? n / len : aiVector3D(0, 0, 1);
      out->normals.emplace_back(n.x, n.y, n.z);
      if (any_colors) {
        if (m->HasVertexColors(0)) {
          const aiColor4D& c = m->mColors[0][v];
          out->colors.emplace_back(c.r, c.g, c.b, c.a);
        } else {
          out->colors.emplace_back(0.7f, 0.7f, 0.7f, 1.0f);
        }
      }
    }
    TriangleMesh::SubMesh sub;
    sub.first_triangle = uint32_t(out->indices.size() / 3);
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices != 3) continue;
      const unsigned a = face.mIndices[0], b = face.mIndices[1], c = face.mIndices[2];
      if (a >= m->mNumVertices || b >= m->mNumVertices || c >= m->mNumVertices) {
        return fail("a face indexes past its vertices");
      }
      // A mirroring transform turns the winding; keep it consistent with the normals.
      out->indices.push_back(base + a);
      out->indices.push_back(base + (det < 0 ? c : b));
      out->indices.push_back(base + (det < 0 ? b : c));
    }
    sub.triangle_count = uint32_t(out->indices.size() / 3) - sub.first_triangle;
    if (sub.triangle_count == 0) continue;
    if (m->mMaterialIndex < scene->mNumMaterials && !stl) {
      const aiMaterial* mat = scene->mMaterials[m->mMaterialIndex];
      aiString name;
      if (mat->Get(AI_MATKEY_NAME, name) == AI_SUCCESS) sub.material.name = name.C_Str();
      aiColor4D diffuse;
      if (sub.material.name != AI_DEFAULT_MATERIAL_NAME &&
          aiGetMaterialColor(mat, AI_MATKEY_COLOR_DIFFUSE, &diffuse) == AI_SUCCESS) {
        float opacity = 1.0f;
        if (mat->Get(AI_MATKEY_OPACITY, opacity) != AI_SUCCESS) opacity = diffuse.a;
        sub.material.rgba = Vec4f(diffuse.r, diffuse.g, diffuse.b, opacity);
        sub.material.has_color = sub.material.rgba.allFinite();
        if (!sub.material.has_color) sub.material.rgba = Material().rgba;
      }
    }
    out->submeshes.push_back(sub);
  }
  if (out->indices.empty()) return fail("the file holds no usable triangles");
  finish_mesh(*out);
  return out;
}

// ---- Running an importer in a child process
//
// assimp 5.2 (Debian 12) dereferences null on some malformed files (found by fuzzing: a Collada
// <float_array count="0"> with numbers in it). A file load therefore runs in a forked child
// that sends the mesh back through a pipe: a crash or a hang of the importer (killed after
// MeshLimits::seconds) becomes a reason, not the end of the process.

void put(std::string& b, const void* p, std::size_t n) {
  b.append(static_cast<const char*>(p), n);
}
template <class T>
void put_pod(std::string& b, const T& v) {
  put(b, &v, sizeof v);
}
template <class T>
void put_vec(std::string& b, const std::vector<T>& v) {
  put_pod(b, uint64_t(v.size()));
  if (!v.empty()) put(b, v.data(), v.size() * sizeof(T));
}
void put_str(std::string& b, const std::string& s) {
  put_pod(b, uint64_t(s.size()));
  put(b, s.data(), s.size());
}

std::string serialize(const TriangleMesh* m, const std::string& error) {
  std::string b;
  put_pod(b, uint32_t(m ? 1 : 0));
  put_str(b, error);
  if (!m) return b;
  put_vec(b, m->positions);
  put_vec(b, m->normals);
  put_vec(b, m->colors);
  put_vec(b, m->indices);
  put_pod(b, uint64_t(m->submeshes.size()));
  for (const auto& s : m->submeshes) {
    put_pod(b, s.first_triangle);
    put_pod(b, s.triangle_count);
    put_pod(b, s.material.rgba);
    put_pod(b, uint8_t(s.material.has_color));
    put_pod(b, uint8_t(s.closed));
    put_pod(b, uint8_t(s.outward));
    put_str(b, s.material.name);
  }
  put_pod(b, m->lower);
  put_pod(b, m->upper);
  put_pod(b, uint8_t(m->closed));
  put_pod(b, uint8_t(m->outward));
  put_str(b, m->warning);
  return b;
}

struct CacheReader {
  const std::string& b;
  std::size_t at = 0;
  bool ok = true;
  bool get(void* p, std::size_t n) {
    if (!ok || n > b.size() - at) return ok = false;
    std::memcpy(p, b.data() + at, n);
    at += n;
    return true;
  }
  template <class T>
  T pod() {
    T v{};
    get(&v, sizeof v);
    return v;
  }
  template <class T>
  void vec(std::vector<T>& v) {
    const uint64_t n = pod<uint64_t>();
    if (!ok || n > (b.size() - at) / sizeof(T)) {
      ok = false;
      return;
    }
    v.resize(n);
    if (n) get(v.data(), n * sizeof(T));
  }
  std::string str() {
    const uint64_t n = pod<uint64_t>();
    if (!ok || n > b.size() - at) {
      ok = false;
      return "";
    }
    std::string s(b.data() + at, n);
    at += n;
    return s;
  }
};

std::shared_ptr<TriangleMesh> deserialize(const std::string& b, std::string* error) {
  CacheReader r{b};
  const uint32_t has = r.pod<uint32_t>();
  const std::string err = r.str();
  if (!r.ok) {
    if (error) *error = "the mesh importer returned nothing";
    return nullptr;
  }
  if (!has) {
    if (error) *error = err;
    return nullptr;
  }
  auto m = std::make_shared<TriangleMesh>();
  r.vec(m->positions);
  r.vec(m->normals);
  r.vec(m->colors);
  r.vec(m->indices);
  const uint64_t ns = r.pod<uint64_t>();
  for (uint64_t k = 0; r.ok && k < ns && k <= m->indices.size(); ++k) {
    TriangleMesh::SubMesh s;
    s.first_triangle = r.pod<uint32_t>();
    s.triangle_count = r.pod<uint32_t>();
    s.material.rgba = r.pod<Vec4f>();
    s.material.has_color = r.pod<uint8_t>() != 0;
    s.closed = r.pod<uint8_t>() != 0;
    s.outward = r.pod<uint8_t>() != 0;
    s.material.name = r.str();
    m->submeshes.push_back(s);
  }
  m->lower = r.pod<Vec3f>();
  m->upper = r.pod<Vec3f>();
  m->closed = r.pod<uint8_t>() != 0;
  m->outward = r.pod<uint8_t>() != 0;
  m->warning = r.str();
  bool sane = r.ok && r.at == b.size() && m->normals.size() == m->positions.size() &&
              (m->colors.empty() || m->colors.size() == m->positions.size());
  for (uint32_t i : m->indices) sane = sane && i < m->positions.size();
  if (!sane) {
    if (error) *error = "the mesh importer returned a damaged mesh";
    return nullptr;
  }
  return m;
}

// Runs make() in a child process; its mesh (or reason) comes back through a pipe.
template <class Make>
std::shared_ptr<TriangleMesh> isolated(Make&& make, const MeshLimits& limits, std::string* error) {
  int fds[2];
  if (::pipe(fds) != 0) return make(error);  // no pipe: in this process, unguarded
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return make(error);
  }
  if (pid == 0) {  // the child: import, send, leave without running the parent's exit code
    ::close(fds[0]);
    std::string err;
    const auto m = make(&err);
    const std::string b = serialize(m.get(), err);
    std::size_t sent = 0;
    while (sent < b.size()) {
      const ssize_t n = ::write(fds[1], b.data() + sent, b.size() - sent);
      if (n <= 0) break;
      sent += std::size_t(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string b;
  char buf[1 << 16];
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(long(1000 * limits.seconds));
  bool timed_out = false;
  for (;;) {
    const long left = long(std::chrono::duration_cast<std::chrono::milliseconds>(
                               deadline - std::chrono::steady_clock::now())
                               .count());
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int r = ::poll(&p, 1, int(std::min(left, 1000L)));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) continue;
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    b.append(buf, std::size_t(n));
  }
  ::close(fds[0]);
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    if (error) *error = "the mesh importer took more than " + std::to_string(limits.seconds) + " s";
    return nullptr;
  }
  if (WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0 && b.empty())) {
    if (error) {
      // A sanitizer in the child turns the signal into an exit status.
      *error = "the mesh importer (assimp) crashed on it (" +
               (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                    : "exit status " + std::to_string(WEXITSTATUS(status))) +
               ")";
    }
    return nullptr;
  }
  return deserialize(b, error);
}

struct CacheEntry {
  std::shared_ptr<const TriangleMesh> mesh;
  std::string error;
};
std::mutex g_cache_mutex;
std::map<std::string, CacheEntry> g_cache;
// Paths kept at most before the entries no one else holds are dropped (a publisher of ever new
// marker resources must not grow it without end).
constexpr std::size_t kMaxCached = 1024;

}  // namespace

std::shared_ptr<TriangleMesh> decode_mesh(const void* data, std::size_t size,
                                          const std::string& hint_in, const MeshLimits& limits,
                                          std::string* error) {
  const std::string hint = lower(hint_in);
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return std::shared_ptr<TriangleMesh>();
  };
  if (!data || size == 0) return fail("empty file");
  if (size > limits.max_bytes) {
    return fail(std::to_string(size) + " bytes (more than the limit of " +
                std::to_string(limits.max_bytes) + ")");
  }
  const auto* bytes = static_cast<const unsigned char*>(data);
  if ((hint == "stl" || hint == "stlb") && !check_stl(bytes, size, limits, error)) return nullptr;
  try {
    Assimp::Importer imp;
    // From memory no other file is read (an OBJ's mtllib, a Collada reference): the memory
    // wrapper hands other names to this IOSystem, which refuses them all.
    imp.SetIOHandler(new GuardedIO("", limits.max_bytes));
    const unsigned flags = configure(imp);
    if (!imp.ReadFileFromMemory(data, size, flags, hint.c_str())) {
      const std::string why = imp.GetErrorString();
      return fail(why.empty() ? std::string("assimp could not read it") : "assimp: " + why);
    }
    const std::string warning = smooth_and_join(imp, limits);
    auto m = mesh_from_scene(imp.GetScene(), hint, limits, error);
    if (m) m->warning = warning;
    return m;
  } catch (const std::exception& e) {
    return fail(std::string("assimp: ") + e.what());
  } catch (...) {
    return fail("assimp failed");
  }
}

std::shared_ptr<const TriangleMesh> load_mesh(const std::string& path, std::string* error,
                                              const MeshLimits& limits) {
  std::error_code ec;
  fs::path canon = fs::weakly_canonical(path, ec);
  const std::string key = ec ? path : canon.string();
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  auto it = g_cache.find(key);
  if (it == g_cache.end()) {
    CacheEntry e;
    const std::string ext = extension_of(key);
    // Only a regular file is read (a FIFO or a device is named as such, never opened to block).
    const std::string what = not_a_regular_file(key);
    if (!what.empty()) {
      e.error = "'" + key + "': " + what;
    } else {
      auto make = [&](std::string* err) -> std::shared_ptr<TriangleMesh> {
        if (ext == "obj") {
          // Through the file system, so that the .mtl beside it is read: only regular files in
          // the mesh's folder and below (GuardedIO).
          try {
            Assimp::Importer imp;
            auto* io = new GuardedIO(fs::path(key).parent_path().string(), limits.max_bytes);
            imp.SetIOHandler(io);  // owned by imp
            if (!imp.ReadFile(key, configure(imp))) {
              if (err) *err = std::string("assimp: ") + imp.GetErrorString();
              if (err && !io->refused().empty()) *err += " (" + io->refused()[0] + ")";
              return nullptr;
            }
            std::string warning = smooth_and_join(imp, limits);
            for (const std::string& r : io->refused()) add_warning(warning, "not read: " + r);
            auto m = mesh_from_scene(imp.GetScene(), ext, limits, err);
            if (m) m->warning = warning;
            return m;
          } catch (const std::exception& x) {
            if (err) *err = std::string("assimp: ") + x.what();
            return nullptr;
          }
        }
        std::string bytes, why;
        if (!read_file(key, bytes, &why, limits.max_bytes)) {
          if (err) *err = "'" + key + "': " + why;
          return nullptr;
        }
        return decode_mesh(bytes.data(), bytes.size(), ext, limits, err);
      };
      auto m = limits.isolate ? isolated(make, limits, &e.error) : make(&e.error);
      if (m) m->source = key;
      e.mesh = m;
    }
    if (e.mesh) e.error.clear();
    if (g_cache.size() >= kMaxCached) {
      // Bounded: what only the cache holds (failures, meshes no one uses) goes first.
      for (auto c = g_cache.begin(); c != g_cache.end();) {
        c = !c->second.mesh || c->second.mesh.use_count() == 1 ? g_cache.erase(c) : std::next(c);
      }
    }
    it = g_cache.emplace(key, std::move(e)).first;
  }
  if (!it->second.mesh && error) *error = it->second.error;
  return it->second.mesh;
}

bool is_mesh_file_type(const std::string& path) {
  // Formats of meshes (not assimp's generic names such as .xml, .raw or .x), where assimp has
  // the importer.
  static const char* const kMeshTypes[] = {"stl",  "dae", "obj", "ply", "off", "3ds", "fbx",
                                           "gltf", "glb", "3mf", "amf", "ac",  "lwo", "ms3d"};
  const std::string ext = extension_of(path);
  if (std::find(std::begin(kMeshTypes), std::end(kMeshTypes), ext) == std::end(kMeshTypes)) {
    return false;
  }
  static const Assimp::Importer probe;
  return probe.IsExtensionSupported("." + ext);
}

void clear_mesh_cache() {
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  g_cache.clear();
}

bool load_mesh_shape(const std::string& uri, const Vec3& scale, const ResourceResolver& resolver,
                     Shape& out, std::string* error) {
  out = Shape();
  out.type = ShapeType::Mesh;
  out.resource = uri;
  out.scale = scale;
  std::string err;
  out.path = resolver ? resolver(uri, &err) : resolve_resource(uri, ResourcePaths(), &err);
  if (out.path.empty()) {
    if (error) *error = err.empty() ? "cannot resolve '" + uri + "'" : err;
    return false;
  }
  if (!scale.allFinite()) {
    if (error) *error = "non-finite mesh scale";
    return false;
  }
  out.mesh = load_mesh(out.path, &err);
  if (!out.mesh) {
    const bool named = err.compare(0, out.path.size() + 2, "'" + out.path + "'") == 0;
    if (error) *error = named ? err : "'" + out.path + "': " + err;
    return false;
  }
  return true;
}

}  // namespace se3
