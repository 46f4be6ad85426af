/* The Embree functions the renderer calls (accel.c), as a table that the module
 * libvf_embree.so (embree_module.c) fills with Embree's own: Embree and TBB are loaded by
 * the processes that trace rays, on their first vf_accel_create, not by every command
 * (common/module.h). Members have the names and types of Embree 3's functions; a call
 * `api->rtcIntersect8(...)` is Embree's. Embree's inline helpers (rtcInitIntersectContext)
 * need no entry. */
#ifndef VF_RENDER_EMBREE_API_H
#define VF_RENDER_EMBREE_API_H

#include "../../common/module.h"

#include <embree3/rtcore.h>

/* Changed whenever the list changes (a module of another version is refused by name). */
#define VF_EMBREE_API_VERSION 1
#define VF_EMBREE_MODULE_FILE "libvf_embree.so"

#define VF_EMBREE_FUNCTIONS(X)                                                                        \
  X(rtcNewDevice) X(rtcReleaseDevice) X(rtcGetDeviceError) X(rtcSetDeviceErrorFunction)              \
  X(rtcNewScene) X(rtcReleaseScene) X(rtcSetSceneBuildQuality) X(rtcSetSceneFlags) X(rtcCommitScene) \
  X(rtcNewGeometry) X(rtcReleaseGeometry) X(rtcSetNewGeometryBuffer) X(rtcSetGeometryUserData)      \
  X(rtcSetGeometryIntersectFilterFunction) X(rtcSetGeometryOccludedFilterFunction)                  \
  X(rtcCommitGeometry) X(rtcAttachGeometryByID)                                                      \
  X(rtcIntersect1) X(rtcOccluded1) X(rtcIntersect8) X(rtcOccluded8)

typedef struct {
  vf_module_head head; /* VF_EMBREE_API_VERSION, sizeof(vf_embree_api) */
  VF_EMBREE_FUNCTIONS(VF_MODULE_MEMBER)
} vf_embree_api;

#endif
