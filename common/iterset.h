/* A set of global iteration indices, kept as sorted, disjoint, coalesced half-open ranges.
 *
 * Films carry one: it is what makes merging and continuing exact, since a film whose set
 * overlaps another's would count samples twice. Text form: "[0,16) [32,64)"; "" is empty. */
#ifndef VF_ITERSET_H
#define VF_ITERSET_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
  uint64_t begin, end; /* [begin, end), begin < end */
} vf_iter_range;

typedef struct {
  vf_iter_range *ranges; /* owned, sorted by begin, disjoint and non-adjacent */
  size_t count, capacity;
} vf_iterset;

void vf_iterset_init(vf_iterset *set);
void vf_iterset_destroy(vf_iterset *set);
int vf_iterset_copy(vf_iterset *dst, const vf_iterset *src);

/* Adds [begin, end). VF_EOVERLAP (set unchanged) if any index is already present. */
int vf_iterset_add(vf_iterset *set, uint64_t begin, uint64_t end);
/* Adds every range of src to dst. VF_EOVERLAP (dst unchanged) if the sets intersect. */
int vf_iterset_union(vf_iterset *dst, const vf_iterset *src);
int vf_iterset_intersects(const vf_iterset *a, const vf_iterset *b);
int vf_iterset_equal(const vf_iterset *a, const vf_iterset *b);
int vf_iterset_contains(const vf_iterset *set, uint64_t index);
uint64_t vf_iterset_count(const vf_iterset *set);
/* The smallest index not in the set at or after `from`. */
uint64_t vf_iterset_next_free(const vf_iterset *set, uint64_t from);

/* Writes the text form, NUL-terminated; VF_EINVAL if it does not fit in n bytes. */
int vf_iterset_format(const vf_iterset *set, char *buf, size_t n);
/* Parses the text form (ranges separated by single spaces, sorted, not adjacent: as
 * vf_iterset_format writes them) in linear time. VF_EINVAL with a detail on anything else;
 * the set is replaced only on success. */
int vf_iterset_parse(vf_iterset *set, const char *text);

#endif
