#include "machine.h"

#include "../common/error.h"

#include <string.h>
#include <unistd.h>

int vf_machine_tags(vf_tags *tags) {
  int err = VF_OK;
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && err == VF_OK) err = vf_tags_add("automatic tags", tags, "avx2", 4, 0);
  if (__builtin_cpu_supports("avx512f") && err == VF_OK) err = vf_tags_add("automatic tags", tags, "avx512", 6, 0);
#endif
  return err;
}

uint64_t vf_machine_memory_bytes(void) {
  long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGESIZE);
  return pages > 0 && size > 0 ? (uint64_t)pages * (uint64_t)size : 0;
}
