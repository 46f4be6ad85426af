/* Vertex merging's fast path: a camera tile's queued queries as a software pipeline whose
 * candidate tests are SIMD (merge_pipeline.c says how and why). It computes, bit for bit,
 * what the reference of vertex_merging.c computes query by query; vertex_merging.h has the
 * overview and vf_vertex_merging_run_tile, the one caller in the renderer.
 *
 * The candidate tests are SSE2 (every x86-64) or AVX-512: VF_MERGE_PIPELINE is defined
 * where the target has the fast path; elsewhere the renderer runs the reference. Private to
 * the renderer. */
#ifndef VF_MERGE_PIPELINE_H
#define VF_MERGE_PIPELINE_H

#include "hashgrid.h"
#include "vcm_internal.h"

#include <stdint.h>

#ifdef __SSE2__
#define VF_MERGE_PIPELINE 1

/* Runs the thread's queued queries as vf_vertex_merging_run_tile promises, testing
 * candidates with AVX-512 when vf_vcm.vertex_merging_avx512 is set, else with SSE2. */
void vf_merge_pipeline_run(vf_vcm *v, int thread, float *tile_rgb);

/* The pipeline's candidate test on its own, for tests: the light vertices of the candidate
 * ranges[0 .. n) that lie within the radius of q and are short enough to merge with it
 * (vf_vertex_merging_one would give the others zero), in the ranges' order. Writes up to
 * max of them to hits, which needs room for max + VF_MERGE_HITS_SLACK (the slots past max
 * take stray writes); returns their number, which may exceed max. AVX-512 when avx512 is
 * set, which only a CPU of which vf_merge_pipeline_detect_avx512 says so may ask for. */
#define VF_MERGE_HITS_SLACK 8

/* The hits the pipeline keeps for a query; the reference merges a query that has more. */
#define VF_MERGE_SLOT_HITS 24
int vf_merge_pipeline_find_hits(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n,
                                uint32_t *hits, int max, int avx512);
#endif

/* Whether this CPU and build test candidates with AVX-512 (F and VL), for
 * vf_vcm.vertex_merging_avx512. */
int vf_merge_pipeline_detect_avx512(void);

#endif
