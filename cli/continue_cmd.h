/* `vcmfarm continue`: render a film's next unused global iterations into it. */
#ifndef VF_CONTINUE_CMD_H
#define VF_CONTINUE_CMD_H

int vf_cmd_continue(int argc, char **argv);

#endif
