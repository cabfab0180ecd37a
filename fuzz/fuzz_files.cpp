// libFuzzer target: the readers of outside files on every kind of path (regular file,
// directory, FIFO, symbolic link to a FIFO, character device, missing), where a FIFO's open or
// read used to block forever. The first byte picks the kind of the file read, the second the
// kind of the material file an OBJ names; the rest is the file's text. read_file, the URDF and
// scene readers and load_mesh (an OBJ with its mtllib, through assimp's guarded IOSystem) must
// return or refuse with a reason naming what the path is, never block (libFuzzer's -timeout
// is the hang check) and never crash.
#include <sys/stat.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/model/model.h"
#include "se3_sim/sim/sim.h"

namespace {

// A folder of this process with one path of each kind (made once).
const std::string& folder() {
  static const std::string dir = [] {
    std::string d = "/tmp/se3_fuzz_files_" + std::to_string(::getpid());
    ::mkdir(d.c_str(), 0700);
    ::mkdir((d + "/dir").c_str(), 0700);
    ::mkfifo((d + "/fifo").c_str(), 0600);
    ::symlink((d + "/fifo").c_str(), (d + "/link_to_fifo").c_str());
    return d;
  }();
  return dir;
}

std::string path_of_kind(uint8_t k) {
  switch (k % 7) {
    case 0:
      return folder() + "/regular";
    case 1:
      return folder() + "/dir";
    case 2:
      return folder() + "/fifo";
    case 3:
      return folder() + "/link_to_fifo";
    case 4:
      return "/dev/null";
    case 5:
      return "/dev/zero";
    default:
      return folder() + "/missing";
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 2, size - 2);
  std::ofstream(folder() + "/regular", std::ios::binary | std::ios::trunc) << text;
  const std::string path = path_of_kind(data[0]);
  std::string out, why;
  if (!se3::read_file(path, out, &why, 1 << 20) && why.empty()) __builtin_trap();
  try {
    se3::model_from_urdf_file(path);
  } catch (const se3::ModelError&) {
  }
  try {
    se3::load_scene(path);
  } catch (const se3::SceneError&) {
  }
  // An OBJ naming a material file of the second kind, by a name relative to the OBJ's folder
  // (as assimp joins it; /dev/... is reached with '..', which the loader refuses).
  std::string mtl = path_of_kind(data[1]);
  mtl = mtl.compare(0, folder().size() + 1, folder() + "/") == 0 ? mtl.substr(folder().size() + 1)
                                                                 : "../../../../../../../.." + mtl;
  std::ofstream(folder() + "/mesh.obj", std::ios::binary | std::ios::trunc)
      << "mtllib " << mtl << "\nusemtl m\n"
      << text.substr(0, 4096);
  se3::clear_mesh_cache();
  se3::MeshLimits limits;
  limits.isolate = false;  // in this process: a block or crash is the fuzzer's to see
  limits.max_bytes = std::size_t(1) << 20;
  std::string error;
  const auto mesh = se3::load_mesh(folder() + "/mesh.obj", &error, limits);
  if (!mesh && error.empty()) __builtin_trap();
  se3::clear_mesh_cache();
  if (!se3::load_mesh(path, &error, limits) && error.empty()) __builtin_trap();
  se3::clear_mesh_cache();
  return 0;
}
