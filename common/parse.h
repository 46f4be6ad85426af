/* Strict parsing of numbers and text from files and the network (film attributes, state
 * files, convergence logs, names). */
#ifndef VF_PARSE_H
#define VF_PARSE_H

#include <stddef.h>
#include <stdint.h>

/* Strict decimal: digits only, no sign or blanks, no overflow. Parses the longest run of
 * digits at s into *out and returns the first character after it, or NULL when there is
 * no digit or the value overflows 64 bits. For text from files and the network. */
const char *vf_parse_u64(const char *s, uint64_t *out);

/* 1 when s[0, n) is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, at
 * most U+10FFFF), else 0. Every text that ends up in a film or in JSON must be: a film's
 * attributes are refused otherwise, and JSON cannot carry other bytes. */
int vf_utf8_valid(const char *s, size_t n);

/* Replaces, in the NUL-terminated s, every byte that does not begin a well-formed UTF-8
 * character (a character cut at the end included) by '?': text from older files or from
 * peers made fit for JSON. */
void vf_utf8_sanitize(char *s);

#endif
