/* VDB files for tests/worker/scene/test_media.c, written with OpenVDB's own API (not
 * through worker/scene/vdb.h), so that reading them checks the reader against the
 * library. */
#ifndef VF_TEST_VDB_FIXTURES_H
#define VF_TEST_VDB_FIXTURES_H

#ifdef __cplusplus
extern "C" {
#endif

enum {
  VDB_FIXTURE_GOOD,       /* float grid "density": the box and values below */
  VDB_FIXTURE_DOUBLE,     /* a double grid named "density" */
  VDB_FIXTURE_ROTATED,    /* the good grid's values under a transform rotated about z */
  VDB_FIXTURE_NEGATIVE,   /* the good grid with one value -1 */
  VDB_FIXTURE_BACKGROUND, /* the good grid with background 0.5 */
  VDB_FIXTURE_HUGE,       /* two active voxels 1000 apart on every axis: 1001^3 samples */
};

/* The good grid: voxel (i, j, k) for i, j, k from lo[] over dims[] voxels is active with
 * value vdb_fixture_value(i, j, k); the transform maps index p to scale * p + translate
 * per axis. */
double vdb_fixture_value(int i, int j, int k);

/* Writes the fixture `kind` with grid name `name` to `path`; 0 on success, -1 (with a
 * message on stderr) on failure. */
int vdb_fixture_write(const char *path, int kind, const char *name, const int lo[3], const int dims[3],
                      const double scale[3], const double translate[3]);

#ifdef __cplusplus
}
#endif

#endif
