/* `vcmfarm coordinator`: serves a farm (coordinator/coordinator.h). */
#ifndef VF_COORDINATOR_CMD_H
#define VF_COORDINATOR_CMD_H

int vf_cmd_coordinator(int argc, char **argv);

#endif
