/* The parts of the microfacet module that run once per material: microfacet.h. */
#include "microfacet.h"

/* 2 int_0^1 F(c) c dc by the midpoint rule: F is smooth in c, so 64 points leave an error
 * of ~1e-4, far below what the lobe selection it feeds could notice. */
vf_vec3 vf_fresnel_conductor_average(vf_vec3 eta, vf_vec3 k) {
  enum { STEPS = 64 };
  double sum[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < STEPS; i++) {
    float c = ((float)i + 0.5f) / (float)STEPS;
    vf_vec3 f = vf_fresnel_conductor(c, eta, k);
    sum[0] += (double)f.x * c;
    sum[1] += (double)f.y * c;
    sum[2] += (double)f.z * c;
  }
  return vf_vec3_make((float)(2.0 * sum[0] / STEPS), (float)(2.0 * sum[1] / STEPS), (float)(2.0 * sum[2] / STEPS));
}
