/* Worker tags and job requirements (docs/PROTOCOL.md, "Tags and requirements").
 *
 * A worker carries tags: the words its operator gives it (`worker --tags night,gpu-room`)
 * and the CPU features it finds itself (`avx2`, `avx512`: worker/machine.h). It also
 * reports its memory as a number. A job requires tags (`submit --require avx512,night`)
 * and is leased only to workers that satisfy every one of them:
 *
 *   - a plain tag is satisfied by a worker carrying exactly that tag (bytes compared,
 *     so `Night` is not `night`);
 *   - `mem>=N` with a unit K, M, G or T (binary: 64G is 64 GiB) is satisfied by a worker
 *     that reported at least that much memory. It is measured, never given: a worker's
 *     own tags may not start with `mem>=`.
 *
 * A tag is 1 to VF_TAG_MAX_BYTES bytes of well-formed UTF-8 without control characters,
 * spaces or commas (the list separator); a list holds at most VF_TAGS_MAX distinct tags
 * (a tag given twice counts once). Text from the command line and from the network is
 * checked by the same functions, and every refusal names the tag and the rule it breaks. */
#ifndef VF_TAGS_H
#define VF_TAGS_H

#include <stddef.h>
#include <stdint.h>

#define VF_TAG_MAX_BYTES 32
#define VF_TAGS_MAX 16
#define VF_TAG_MEMORY_PREFIX "mem>="

typedef struct {
  unsigned count;
  char tag[VF_TAGS_MAX][VF_TAG_MAX_BYTES + 1];
} vf_tags;

/* An empty list. */
void vf_tags_init(vf_tags *tags);

/* Checks tag[0, len) as a tag, or with `requirement` set as a requirement (a plain tag or
 * a well-formed `mem>=N` with its unit; a plain tag may not start with `mem>=`). VF_EINVAL
 * with a detail "WHAT: ..." naming the tag and what is wrong with it. */
int vf_tag_check(const char *what, const char *tag, size_t len, int requirement);

/* Appends tag[0, len) after vf_tag_check; nothing when the list has it already. VF_EINVAL
 * (detail naming WHAT) when it is malformed or the list is full. */
int vf_tags_add(const char *what, vf_tags *tags, const char *tag, size_t len, int requirement);

/* Appends each item of the comma-separated `list` (vf_tags_add): an empty item (",,", a
 * leading or trailing comma, an empty list) is refused. On failure *tags keeps what it had. */
int vf_tags_parse(const char *what, const char *list, vf_tags *tags, int requirement);

/* 1 when the worker of `tags` and `memory_bytes` (0: unknown, satisfies no memory
 * requirement) satisfies every requirement of `requires`; else 0, and *missing (may be
 * NULL) is the first requirement it does not. */
int vf_tags_satisfied(const vf_tags *requires, const vf_tags *tags, uint64_t memory_bytes, const char **missing);

/* The bytes a well-formed `mem>=N` requirement asks for, or 0 for a plain tag. */
uint64_t vf_tag_memory(const char *tag);

/* The list as "a,b,c" ("" when empty), cut to fit n bytes. */
void vf_tags_format(const vf_tags *tags, char *buf, size_t n);

#endif
