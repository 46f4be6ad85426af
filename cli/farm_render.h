/* `vcmfarm render` without --direct: the render through an in-process coordinator and
 * worker (docs/PROTOCOL.md, "One machine"). */
#ifndef VF_FARM_RENDER_H
#define VF_FARM_RENDER_H

#include "render_job.h"

/* Renders the job through the farm's code and writes its film to job->output (and the
 * preview); prints progress and summary unless job->quiet. Returns an exit status
 * (VF_EXIT_*), having printed the error. */
int vf_farm_render(const vf_render_job *job);

#endif
