/* `vcmfarm render`: renders global iterations of a scene into a film. */
#ifndef VF_RENDER_CMD_H
#define VF_RENDER_CMD_H

int vf_cmd_render(int argc, char **argv);

#endif
