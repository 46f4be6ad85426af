#include "interrupt.h"

#include <string.h>

volatile sig_atomic_t vf_interrupted;

static void on_interrupt(int sig) {
  (void)sig;
  vf_interrupted = 1;
}

void vf_interrupt_catch(vf_interrupt_saved *saved) {
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  vf_interrupted = 0;
  sigaction(SIGINT, &sa, &saved->old_int);
  sigaction(SIGTERM, &sa, &saved->old_term);
}

void vf_interrupt_restore(const vf_interrupt_saved *saved) {
  sigaction(SIGINT, &saved->old_int, NULL);
  sigaction(SIGTERM, &saved->old_term, NULL);
}
