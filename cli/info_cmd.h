/* `vcmfarm info FILM [--json]`: everything a film knows about itself. */
#ifndef VF_INFO_CMD_H
#define VF_INFO_CMD_H

int vf_cmd_info(int argc, char **argv);

#endif
