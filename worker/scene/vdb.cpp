// OpenVDB float grids <-> the scene model's dense density grids (vdb.h): the scene
// library's OpenVDB module, libvf_vdb.so, loaded by vdb.c on the first use of a grid
// (vdb_module.h says why and how). The only C++ of the scene library: exceptions are caught
// here and become VF_* codes with a detail, recorded through the program's vf_error_set,
// which the module is handed when it is opened. It exports one symbol, its entry point.
// The project's headers are C: their declarations keep C linkage.
extern "C" {
#include "vdb_module.h"

#include "../../common/error.h"
}

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <dlfcn.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <sstream>
#include <string>

namespace {

// The program's vf_error_set (vf_module_open sets it before handing out the table).
vf_module_error_fn report_error = nullptr;

// Debian's OpenVDB links log4cplus 2.0, whose library starts a pool of four logging
// threads as it loads: in every process that links the scene library, whether it reads a
// grid or not. A process with those threads that forks has children that cannot exit()
// (log4cplus's finalizer waits for pool threads a child does not have: the tests' forked
// decoders hung). Nothing here logs through log4cplus, so the pool is stopped before main;
// looked up by name, so that a log4cplus without it (or none) is no error.
__attribute__((constructor)) void stop_log4cplus_thread_pool() {
  using shutdown_fn = void (*)();
  void *symbol = dlsym(RTLD_DEFAULT, "_ZN9log4cplus18shutdownThreadPoolEv");  // log4cplus::shutdownThreadPool()
  if (symbol != nullptr) reinterpret_cast<shutdown_fn>(symbol)();
}

// A scale along each axis and a translation, the only maps a dense axis-aligned grid
// can follow; the others are refused by name.
bool axis_aligned(const openvdb::math::Transform &t, openvdb::Vec3d *scale) {
  const openvdb::Vec3d o = t.indexToWorld(openvdb::Vec3d(0, 0, 0));
  for (int a = 0; a < 3; a++) {
    openvdb::Vec3d unit(0, 0, 0);
    unit[a] = 1.0;
    const openvdb::Vec3d d = t.indexToWorld(unit) - o;
    for (int b = 0; b < 3; b++)
      if (b != a && !(std::fabs(d[b]) <= 1e-9 * std::fabs(d[a]))) return false;
    if (!(d[a] > 0.0) || !std::isfinite(d[a])) return false;
    (*scale)[a] = d[a];
  }
  return true;
}

int to_dense(const openvdb::GridBase::Ptr &base, const char *label, const char *grid_name, vf_density_grid *out) {
  if (!base->isType<openvdb::FloatGrid>())
    return report_error(VF_ESCENE, "%s: grid '%s' holds %s values: a density grid must hold floats", label, grid_name,
                        base->valueType().c_str());
  openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  const openvdb::math::Transform &t = grid->transform();
  openvdb::Vec3d scale;
  if (!t.isLinear() || !axis_aligned(t, &scale))
    return report_error(VF_ESCENE, "%s: grid '%s' has a %s transform that is not a positive scale per axis and a "
                        "translation (rotated, sheared, mirrored or frustum grids are not supported)", label,
                        grid_name, t.mapType().c_str());
  const float background = grid->background();
  if (background != 0.0f)
    return report_error(VF_ESCENE, "%s: grid '%s' has background %g: a density grid must be 0 outside its voxels",
                        label, grid_name, (double)background);
  const openvdb::CoordBBox bbox = grid->evalActiveVoxelBoundingBox();
  if (bbox.empty()) return report_error(VF_ESCENE, "%s: grid '%s' has no active voxels", label, grid_name);
  const openvdb::Coord dim = bbox.dim();
  const uint64_t count = (uint64_t)dim.x() * (uint64_t)dim.y() * (uint64_t)dim.z();
  if (count > VF_GRID_MAX_SAMPLES)
    return report_error(VF_ESCENE, "%s: grid '%s' spans %d x %d x %d voxels, more than the %u samples a scene "
                        "may load (docs/SCENES.md, \"Media\")", label, grid_name, dim.x(), dim.y(), dim.z(),
                        (unsigned)VF_GRID_MAX_SAMPLES);
  const openvdb::Vec3d lo = t.indexToWorld(bbox.min().asVec3d() - openvdb::Vec3d(0.5));
  const openvdb::Vec3d hi = t.indexToWorld(bbox.max().asVec3d() + openvdb::Vec3d(0.5));
  for (int a = 0; a < 3; a++)
    if (!(std::fabs(lo[a]) <= 1e30 && std::fabs(hi[a]) <= 1e30 && (float)lo[a] < (float)hi[a]))
      return report_error(VF_ESCENE, "%s: grid '%s' has a world box out of range", label, grid_name);
  float *density = static_cast<float *>(std::malloc(count * sizeof(float)));
  if (density == nullptr) return report_error(VF_ENOMEM, "out of memory");
  float max_density = 0.0f;
  openvdb::FloatGrid::ConstAccessor acc = grid->getConstAccessor();
  size_t i = 0;
  for (int z = bbox.min().z(); z <= bbox.max().z(); z++)
    for (int y = bbox.min().y(); y <= bbox.max().y(); y++)
      for (int x = bbox.min().x(); x <= bbox.max().x(); x++, i++) {
        const float v = acc.getValue(openvdb::Coord(x, y, z));
        if (!(v >= 0.0f && v <= 3.0e38f)) {
          std::free(density);
          return report_error(VF_ESCENE, "%s: grid '%s' has density %g at voxel (%d, %d, %d): densities must be "
                              "finite and >= 0", label, grid_name, (double)v, x, y, z);
        }
        max_density = v > max_density ? v : max_density;
      }
  i = 0;
  for (int z = bbox.min().z(); z <= bbox.max().z(); z++)
    for (int y = bbox.min().y(); y <= bbox.max().y(); y++)
      for (int x = bbox.min().x(); x <= bbox.max().x(); x++) density[i++] = acc.getValue(openvdb::Coord(x, y, z));
  vf_density_grid g;
  std::memset(&g, 0, sizeof g);
  g.nx = (uint32_t)dim.x(), g.ny = (uint32_t)dim.y(), g.nz = (uint32_t)dim.z();
  g.density = density;
  g.box_min.x = (float)lo[0], g.box_min.y = (float)lo[1], g.box_min.z = (float)lo[2];
  g.box_max.x = (float)hi[0], g.box_max.y = (float)hi[1], g.box_max.z = (float)hi[2];
  g.max_density = max_density;
  std::snprintf(g.source, sizeof g.source, "%s", label);
  *out = g;
  return VF_OK;
}

// The grid named grid_name among grids (a file's or a stream's), or an error listing
// what there is.
int pick(const openvdb::GridPtrVecPtr &grids, const char *label, const char *grid_name, openvdb::GridBase::Ptr *out) {
  std::string names;
  for (const openvdb::GridBase::Ptr &g : *grids) {
    if (g->getName() == grid_name) {
      *out = g;
      return VF_OK;
    }
    names += (names.empty() ? "" : ", ") + ("'" + g->getName() + "'");
  }
  return report_error(VF_ESCENE, "%s: no grid named '%s' (the file has %s)", label, grid_name,
                      names.empty() ? "no grids" : names.c_str());
}

int damaged(const char *label, const char *what) {
  return report_error(VF_ESCENE, "%s: not a readable VDB file (%s)", label, what);
}

openvdb::FloatGrid::Ptr to_vdb(const vf_density_grid *g, const char *grid_name) {
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
  grid->setName(grid_name);
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  const openvdb::Vec3d lo(g->box_min.x, g->box_min.y, g->box_min.z), hi(g->box_max.x, g->box_max.y, g->box_max.z);
  const openvdb::Vec3d scale((hi[0] - lo[0]) / g->nx, (hi[1] - lo[1]) / g->ny, (hi[2] - lo[2]) / g->nz);
  openvdb::math::MapBase::Ptr map(new openvdb::math::ScaleTranslateMap(scale, lo + 0.5 * scale));
  grid->setTransform(openvdb::math::Transform::Ptr(new openvdb::math::Transform(map)));
  openvdb::FloatGrid::Accessor acc = grid->getAccessor();
  size_t i = 0;
  // Every sample active, zeros too, so the active box (what a reader takes) is the grid's.
  for (uint32_t z = 0; z < g->nz; z++)
    for (uint32_t y = 0; y < g->ny; y++)
      for (uint32_t x = 0; x < g->nx; x++) acc.setValueOn(openvdb::Coord((int)x, (int)y, (int)z), g->density[i++]);
  return grid;
}

// The file's content when it holds grid g alone, named grid_name.
openvdb::GridPtrVec one_grid(const vf_density_grid *g, const char *grid_name) {
  openvdb::initialize();
  openvdb::GridPtrVec grids;
  grids.push_back(to_vdb(g, grid_name));
  return grids;
}

int check_writable(const vf_density_grid *g) {
  if (g->nx == 0 || g->ny == 0 || g->nz == 0 || g->density == nullptr ||
      (uint64_t)g->nx * g->ny * g->nz > VF_GRID_MAX_SAMPLES || !(g->box_min.x < g->box_max.x) ||
      !(g->box_min.y < g->box_max.y) || !(g->box_min.z < g->box_max.z))
    return report_error(VF_EINVAL, "a density grid to write must have samples and a box of positive size");
  return VF_OK;
}


// Runs body, OpenVDB's exceptions becoming errors that name the file: out of memory, or
// a file OpenVDB cannot read.
template <class Body>
int guarded(const char *label, Body body) {
  try {
    openvdb::initialize();
    return body();
  } catch (const std::bad_alloc &) {
    return report_error(VF_ENOMEM, "out of memory");
  } catch (const std::exception &e) {
    return damaged(label, e.what());
  } catch (...) {
    return damaged(label, "unknown error");
  }
}

// A stream that throws on a short read: OpenVDB reads a block's size without checking the
// read, so from a truncated file it would go on with whatever the variable held (seen: a
// request for 128 TiB, which AddressSanitizer aborts on and a release build reports as out
// of memory); with failbit raising, the read that runs past the end is the error.
template <class Stream>
int read_stream(Stream &in, const char *label, const char *grid_name, vf_density_grid *out) {
  in.exceptions(std::ios_base::failbit | std::ios_base::badbit);
  openvdb::io::Stream stream(in, false);  // every grid read now
  openvdb::GridBase::Ptr base;
  int err = pick(stream.getGrids(), label, grid_name, &base);
  return err < 0 ? err : to_dense(base, label, grid_name, out);
}

int read_grid(const char *path, const char *label, const char *grid_name, vf_density_grid *out) {
  FILE *f = std::fopen(path, "rb");
  if (f == nullptr) return report_error(VF_ENOENT, "%s: cannot open: %s", label, std::strerror(errno));
  std::fclose(f);
  return guarded(label, [&] {
    std::ifstream in(path, std::ios_base::binary);
    return read_stream(in, label, grid_name, out);
  });
}

int read_grid_memory(const void *data, size_t size, const char *label, const char *grid_name,
                                       vf_density_grid *out) {
  return guarded(label, [&] {
    std::istringstream in(std::string(static_cast<const char *>(data), size), std::ios_base::binary);
    return read_stream(in, label, grid_name, out);
  });
}

int write_grid_memory(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size) {
  int err = check_writable(grid);
  if (err < 0) return err;
  try {
    const openvdb::GridPtrVec grids = one_grid(grid, grid_name);
    std::ostringstream os(std::ios_base::binary);
    openvdb::io::Stream(os).write(grids);
    const std::string bytes = os.str();
    void *copy = std::malloc(bytes.size());
    if (copy == nullptr) return report_error(VF_ENOMEM, "out of memory");
    std::memcpy(copy, bytes.data(), bytes.size());
    *data = copy;
    *size = bytes.size();
    return VF_OK;
  } catch (const std::bad_alloc &) {
    return report_error(VF_ENOMEM, "out of memory");
  } catch (const std::exception &e) {
    return report_error(VF_EIO, "writing a VDB grid: %s", e.what());
  }
}

int write_grid(const vf_density_grid *grid, const char *grid_name, const char *path) {
  int err = check_writable(grid);
  if (err < 0) return err;
  try {
    const openvdb::GridPtrVec grids = one_grid(grid, grid_name);
    openvdb::io::File file(path);
    file.write(grids);
    file.close();
    return VF_OK;
  } catch (const std::bad_alloc &) {
    return report_error(VF_ENOMEM, "out of memory");
  } catch (const std::exception &e) {
    return report_error(VF_EIO, "%s: cannot write: %s", path, e.what());
  }
}

const vf_vdb_module module = {{VF_VDB_MODULE_VERSION, sizeof(vf_vdb_module)}, read_grid, read_grid_memory, write_grid_memory, write_grid};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set) {
  if (version != VF_VDB_MODULE_VERSION || error_set == nullptr) return nullptr;
  report_error = error_set;
  return &module;
}
