// VDB files for test_media.c through OpenVDB's API (vdb_fixtures.h).
#include "vdb_fixtures.h"

#include <openvdb/openvdb.h>

#include <cmath>
#include <cstdio>
#include <exception>

extern "C" double vdb_fixture_value(int i, int j, int k) { return 0.5 + 0.25 * (i + 2) + 0.125 * j * j + 0.0625 * k; }

namespace {

template <typename GridT>
typename GridT::Ptr filled(const int lo[3], const int dims[3], typename GridT::ValueType background) {
  typename GridT::Ptr grid = GridT::create(background);
  typename GridT::Accessor acc = grid->getAccessor();
  for (int k = lo[2]; k < lo[2] + dims[2]; k++)
    for (int j = lo[1]; j < lo[1] + dims[1]; j++)
      for (int i = lo[0]; i < lo[0] + dims[0]; i++)
        acc.setValueOn(openvdb::Coord(i, j, k), (typename GridT::ValueType)vdb_fixture_value(i, j, k));
  return grid;
}

}  // namespace

extern "C" int vdb_fixture_write(const char *path, int kind, const char *name, const int lo[3], const int dims[3],
                                 const double scale[3], const double translate[3]) {
  try {
    openvdb::initialize();
    openvdb::math::Transform::Ptr transform(new openvdb::math::Transform(openvdb::math::MapBase::Ptr(
        new openvdb::math::ScaleTranslateMap(openvdb::Vec3d(scale[0], scale[1], scale[2]),
                                             openvdb::Vec3d(translate[0], translate[1], translate[2])))));
    openvdb::GridBase::Ptr grid;
    if (kind == VDB_FIXTURE_DOUBLE) {
      grid = filled<openvdb::DoubleGrid>(lo, dims, 0.0);
    } else {
      openvdb::FloatGrid::Ptr g = filled<openvdb::FloatGrid>(lo, dims, kind == VDB_FIXTURE_BACKGROUND ? 0.5f : 0.0f);
      if (kind == VDB_FIXTURE_NEGATIVE) g->getAccessor().setValueOn(openvdb::Coord(lo[0], lo[1], lo[2]), -1.0f);
      if (kind == VDB_FIXTURE_HUGE) {
        g->clear();
        g->getAccessor().setValueOn(openvdb::Coord(0, 0, 0), 1.0f);
        g->getAccessor().setValueOn(openvdb::Coord(1000, 1000, 1000), 1.0f);
      }
      if (kind == VDB_FIXTURE_ROTATED) transform->preRotate(0.3, openvdb::math::Z_AXIS);
      grid = g;
    }
    grid->setTransform(transform);
    grid->setName(name);
    openvdb::GridPtrVec grids{grid};
    openvdb::io::File file(path);
    file.write(grids);
    file.close();
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "vdb_fixture_write %s: %s\n", path, e.what());
    return -1;
  }
}
