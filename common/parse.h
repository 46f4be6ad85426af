/* Strict parsing of numbers in text from files and the network (film attributes, state
 * files, convergence logs). */
#ifndef VF_PARSE_H
#define VF_PARSE_H

#include <stdint.h>

/* Strict decimal: digits only, no sign or blanks, no overflow. Parses the longest run of
 * digits at s into *out and returns the first character after it, or NULL when there is
 * no digit or the value overflows 64 bits. For text from files and the network. */
const char *vf_parse_u64(const char *s, uint64_t *out);

#endif
