/* Mitsuba 3 sensors and the integrator (mitsuba_sensor.c): a <sensor> with its <film> and
 * <sampler> as the JSON scene's "camera", an <integrator> as its "render" settings, with
 * Mitsuba's conventions (fov axis, orthographic extent, max_depth) of docs/SCENES.md,
 * "Mitsuba 3 scenes". Private to worker/scene/. */
#ifndef VF_SCENE_MITSUBA_SENSOR_H
#define VF_SCENE_MITSUBA_SENSOR_H

#include "mitsuba_props.h"

/* Adds "camera" (with its resolution) to c->root; errors name the element (mts_fail). */
int mts_sensor(mts_ctx *c, vf_xml_node *sensor);
/* Adds "render": {"max_path_length"}; max_depth 0 or below -1 is refused. */
int mts_integrator(mts_ctx *c, vf_xml_node *integrator);

#endif
