/* SIGINT and SIGTERM for the commands that render or serve: the first ends the work at its
 * next safe point (after the current iteration; a worker ships what it rendered), and the
 * handlers are the commands' only ones. */
#ifndef VF_INTERRUPT_H
#define VF_INTERRUPT_H

#include <signal.h>

/* Set to 1 by SIGINT or SIGTERM while caught; the render loop and the worker poll it. */
extern volatile sig_atomic_t vf_interrupted;

/* The handlers a command replaced, to put back when it ends. */
typedef struct {
  struct sigaction old_int, old_term;
} vf_interrupt_saved;

/* Clears vf_interrupted and catches SIGINT and SIGTERM into it, saving the old handlers. */
void vf_interrupt_catch(vf_interrupt_saved *saved);
/* Puts the handlers that vf_interrupt_catch replaced back. */
void vf_interrupt_restore(const vf_interrupt_saved *saved);

#endif
