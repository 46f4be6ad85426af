/* Arrays that the renderer reads at random (photons, the grid's sorted points): on 2 MiB
 * pages where the kernel has them (transparent huge pages, which Debian enables on
 * request), so that their tens of megabytes need a few dozen TLB entries instead of
 * thousands. Private to the renderer. */
#ifndef VF_HUGE_PAGES_H
#define VF_HUGE_PAGES_H

#include <stddef.h>
#include <stdlib.h>
#include <sys/mman.h>

#define VF_HUGE_PAGE ((size_t)2 << 20)

/* At least `bytes`, aligned to a huge page, contents undefined; NULL when out of memory.
 * Freed with free(). */
static inline void *vf_huge_alloc(size_t bytes) {
  bytes = (bytes + VF_HUGE_PAGE - 1) / VF_HUGE_PAGE * VF_HUGE_PAGE; /* aligned_alloc: a multiple of the alignment */
  void *p = aligned_alloc(VF_HUGE_PAGE, bytes);
#ifdef MADV_HUGEPAGE
  if (p != NULL) madvise(p, bytes, MADV_HUGEPAGE); /* advice only: 4 KiB pages if refused */
#endif
  return p;
}

/* Gives the whole huge pages of the first `bytes` of p (from vf_huge_alloc) back to the
 * kernel: they read as zeros when touched again. */
static inline void vf_huge_release(void *p, size_t bytes) {
  bytes = bytes / VF_HUGE_PAGE * VF_HUGE_PAGE;
  if (p != NULL && bytes > 0) madvise(p, bytes, MADV_DONTNEED);
}

#endif
