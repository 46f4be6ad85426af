/* The convergence log: how a film's error fell while it was rendered (paper sec. 7 plots
 * RMS error against time). Each entry measures the film at one checkpoint.
 *
 * Entries belong to runs. A run is one unbroken history of one film: `render` starts run
 * 0, `continue` goes on in the same run when the film has not changed since the run's last
 * entry, and starts a new run otherwise (after a merge, say). vf_film_merge keeps the
 * destination's entries and appends the source's with their runs renumbered after the
 * destination's, so `plot` draws each run as its own stroke and a merged film still shows
 * how each of its parts converged. An entry's times and iteration count are those of the
 * film it was measured on, which after a merge is only a part of the result.
 *
 * On disk it is the film attribute "vcmfarm:convergence" (docs/FILM.md), one line per entry:
 *   "RUN WALL CPU ITERATIONS RMSE REL_MSE ESTIMATE\n"
 * with RUN and ITERATIONS decimal, the rest as C doubles (%.9g) and "nan" where a value is
 * unknown (no reference). */
#ifndef VF_CONVERGENCE_H
#define VF_CONVERGENCE_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
  uint32_t run;          /* which run of the film's history (see above) */
  double wall_seconds;   /* the film's render_seconds when measured */
  double cpu_seconds;    /* the film's cpu_seconds when measured */
  uint64_t iterations;   /* iterations the film held */
  double rmse;           /* against the reference; NaN without one */
  double rel_mse;        /* relative MSE against the reference (common/metrics.h); NaN without one */
  double estimated_rmse; /* vf_film_estimate_rmse, no reference needed; NaN below 2 iterations */
} vf_convergence_entry;

typedef struct {
  vf_convergence_entry *entries; /* owned */
  size_t count, capacity;
} vf_convergence_log;

void vf_convergence_init(vf_convergence_log *log);
void vf_convergence_destroy(vf_convergence_log *log); /* frees the entries; the log is empty after */

/* Copies src into dst, which must be empty (initialised). VF_ENOMEM, dst unchanged. */
int vf_convergence_copy(vf_convergence_log *dst, const vf_convergence_log *src);
/* Makes room for `more` further entries, so that appending them cannot fail. VF_ENOMEM. */
int vf_convergence_reserve(vf_convergence_log *log, size_t more);
/* Appends one entry (VF_ENOMEM, log unchanged). Does not validate it. */
int vf_convergence_append(vf_convergence_log *log, const vf_convergence_entry *entry);
/* Appends src's entries with their runs moved after dst's last run. Room must have been
 * reserved (vf_convergence_reserve), so this cannot fail. */
void vf_convergence_append_runs(vf_convergence_log *dst, const vf_convergence_log *src);

/* The run a new entry for a film now holding `iterations` iterations and `wall_seconds` of
 * rendering belongs to: the last entry's run if it measured this same film state (the same
 * iteration count), else a new one. */
uint32_t vf_convergence_next_run(const vf_convergence_log *log, uint64_t iterations, double wall_seconds);

/* Checks every entry: times finite and >= 0, errors NaN or finite and >= 0, runs never
 * decreasing. VF_EFILM with "NAME: attribute vcmfarm:convergence: entry K: problem". */
int vf_convergence_validate(const vf_convergence_log *log, const char *name);

/* The text form above in a new NUL-terminated string (*out, caller frees). VF_ENOMEM. */
int vf_convergence_format(const vf_convergence_log *log, char **out);
/* Parses the text form into an empty log and validates it. VF_EFILM with a detail naming
 * `name`, the attribute and the line on malformed text; the log is left empty then. */
int vf_convergence_parse(vf_convergence_log *log, const char *text, const char *name);

#endif
