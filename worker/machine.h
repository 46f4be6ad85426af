/* What a worker finds out about its machine for the coordinator's matching of jobs to
 * workers (common/tags.h): the CPU features a job may require, as automatic tags, and the
 * memory a `mem>=N` requirement is compared with. Found once, at registration. */
#ifndef VF_MACHINE_H
#define VF_MACHINE_H

#include "../common/tags.h"

#include <stdint.h>

/* Adds the automatic tags of this CPU to *tags: `avx2` where it has AVX2, `avx512` where
 * it has AVX-512 F (the foundation every AVX-512 CPU has; the renderer's merge pipeline
 * uses it). A full list takes what fits and VF_EINVAL is returned with the detail. */
int vf_machine_tags(vf_tags *tags);

/* The machine's physical memory in bytes; 0 when it cannot be known. */
uint64_t vf_machine_memory_bytes(void);

#endif
