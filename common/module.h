/* Optional parts of the program as shared modules, each opened on its first use.
 *
 * Embree (and TBB), Assimp, cairo (and its X11 and font stack), libmicrohttpd (and
 * GnuTLS) and OpenVDB (and Boost, log4cplus) each cost every process that links them
 * 5-40 ms of dynamic linking, relocation and static constructors at start, whether it
 * renders, imports, draws or serves anything or not: `vcmfarm info` would pay for all of
 * them. So the program links none of them. Each is wrapped by a module, libvf_NAME.so,
 * that links its library and exports one symbol, VF_MODULE_ENTRY, returning a table: of
 * the library's functions the program calls (embree_api.h, assimp_api.h, cairo_api.h,
 * http_api.h) or of operations of its own (vdb_module.h). A process loads a module when it
 * first needs it, and only then.
 *
 * Where a module is looked for, first found wins:
 *   1. beside the running program (/proc/self/exe's folder): the build tree's vcmfarm;
 *   2. in ../lib/vcmfarm/ from there: an installed vcmfarm (`cmake --install`, the
 *      container image), wherever its prefix is;
 *   3. in the build tree that compiled this library (VF_MODULE_BUILD_DIR): its tests and
 *      tools, whose programs live in folders of their own.
 * A module that is found but cannot be loaded, or serves another version or table size,
 * is an error naming it; none found is an error naming every place looked in. Either fails
 * the operation that wanted it, and only that. */
#ifndef VF_COMMON_MODULE_H
#define VF_COMMON_MODULE_H

#include <pthread.h>
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VF_MODULE_ENTRY "vf_module_open"

/* The first member of every module's table. `version` changes whenever the table's
 * members or the types it passes change; `size` is sizeof the table, a second guard. */
typedef struct {
  int version;
  size_t size;
} vf_module_head;

/* The program's vf_error_set, handed to the module: the error detail is thread-local
 * state of the program's common/error.c, which a module does not link. */
typedef int (*vf_module_error_fn)(int code, const char *fmt, ...);
/* VF_MODULE_ENTRY's type: the table for `version`, or NULL when the module cannot serve
 * it. The table lives as long as the process. */
typedef const void *(*vf_module_open_fn)(int version, vf_module_error_fn error_set);

/* A table of a library's functions, declared from an X-macro list of their names:
 *   #define VF_FOO_FUNCTIONS(X) X(foo_open) X(foo_close)
 *   typedef struct { vf_module_head head; VF_FOO_FUNCTIONS(VF_MODULE_MEMBER) } vf_foo_api;
 * gives each member the name and the type of the library's function, so that
 * `api->foo_open(...)` is the library's call; and in the module's one source file,
 *   VF_MODULE_FUNCTIONS(vf_foo_api, VF_FOO_API_VERSION, VF_FOO_FUNCTIONS)
 * defines the table and VF_MODULE_ENTRY, which hands it out for that version only. */
#define VF_MODULE_MEMBER(f) __typeof__(&f) f;
#define VF_MODULE_ADDRESS_(f) &f,
#define VF_MODULE_FUNCTIONS(type, version_number, LIST)                                                  \
  static const type vf_module_table_ = {{(version_number), sizeof(type)}, LIST(VF_MODULE_ADDRESS_)};     \
  __attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set); \
  const void *vf_module_open(int version, vf_module_error_fn error_set) {                                \
    (void)error_set;                                                                                     \
    return version == (version_number) ? &vf_module_table_ : NULL;                                       \
  }

/* One module as the program sees it; a file-scope static, VF_MODULE_INIT'ed. */
typedef struct {
  const char *file;  /* "libvf_embree.so" */
  const char *what;  /* what it serves, for messages: "Embree ray tracing" */
  int version;       /* the table version wanted */
  size_t size;       /* sizeof the table wanted */
  pthread_mutex_t lock;
  int tried;
  const void *table; /* NULL until loaded, or when it cannot be (atomic) */
  char failure[2048]; /* why it cannot be, for every caller after the first */
} vf_module;

#define VF_MODULE_INIT(file, what, version, size) \
  { (file), (what), (version), (size), PTHREAD_MUTEX_INITIALIZER, 0, NULL, { 0 } }

/* The module's table, loading it on the first call (thread-safe; once loaded, a call is an
 * atomic load); NULL when it cannot be had, with VF_EMODULE set (common/error.h), its
 * detail "LABEL: why". */
const void *vf_module_get(vf_module *m, const char *label);

#ifdef __cplusplus
}
#endif

#endif
