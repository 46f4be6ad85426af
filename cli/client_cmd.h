/* The users' side of the farm: `vcmfarm submit`, `status`, `fetch`, `cancel`, `remove`,
 * `pause`, `resume`, and
 * `keygen` for the shared key every peer needs. */
#ifndef VF_CLIENT_CMD_H
#define VF_CLIENT_CMD_H

int vf_cmd_submit(int argc, char **argv);
int vf_cmd_status(int argc, char **argv);
int vf_cmd_fetch(int argc, char **argv);
int vf_cmd_cancel(int argc, char **argv);
int vf_cmd_remove(int argc, char **argv);
int vf_cmd_pause(int argc, char **argv);
int vf_cmd_resume(int argc, char **argv);
int vf_cmd_keygen(int argc, char **argv);

#endif
