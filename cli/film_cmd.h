/* Film tools: the subcommands that combine and export films (docs/TOOLS.md), and the
 * reader that lets any film or plain RGB EXR serve as an image or a reference.
 *
 * Each vf_cmd_* takes the subcommand's own argv (argv[0] is the subcommand name), prints
 * its errors as "vcmfarm CMD: detail" on stderr and returns an exit status: 0 success,
 * 1 failure while working (out of memory, disk full), 2 bad input (command line, a file
 * that is missing, damaged, not a film, or films that do not fit together). On status 2
 * nothing is written: every input is read and checked before the output is created, and
 * outputs are written atomically (temporary file, fsync, rename), so an existing file at
 * the output path is left exactly as it was. The functions reset getopt and may be called
 * repeatedly in one process (the tests do); they are not thread-safe (getopt). */
#ifndef VF_FILM_CMD_H
#define VF_FILM_CMD_H

#include "../common/image.h"

/* vcmfarm merge -o OUT IN...: the exact sum of two or more films. Refuses films whose
 * size, scene hash or settings text differ from the first input's, and films whose
 * iteration sets overlap, naming both files. OUT may be one of the inputs. Says on
 * stderr what it wrote, one line, unless -q. */
int vf_cmd_merge(int argc, char **argv);

/* vcmfarm bake FILM -o IMAGE.exr|IMAGE.png [--exposure E]: the film's mean as a clean
 * FLOAT RGB EXR, or as an 8-bit sRGB PNG scaled by 2^E. Other extensions are refused.
 * Says on stderr what it wrote, one line, unless -q. */
int vf_cmd_bake(int argc, char **argv);

/* Reads path as an RGB image into *out (written only on success; the caller frees it with
 * vf_image_destroy). A file carrying the film attribute vcmfarm:format_version is read as
 * a film (vf_film_read: all its checks apply) and gives its mean; any other file is read
 * by vf_image_read_exr. *is_film (may be NULL) says which, only on success. Errors are
 * those of the two readers (VF_ENOENT, VF_EIO, VF_EEXR, VF_EFILM, VF_ENOMEM) with one
 * detail naming the file; a damaged file gives one error, never a second attempt. */
int vf_reference_read(const char *path, vf_image *out, int *is_film);

#endif
