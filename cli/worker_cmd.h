/* `vcmfarm worker`: renders leases of a farm's jobs (docs/PROTOCOL.md). */
#ifndef VF_WORKER_CMD_H
#define VF_WORKER_CMD_H

int vf_cmd_worker(int argc, char **argv);

#endif
