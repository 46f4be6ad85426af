/* Scattering at a surface vertex: evaluation, sampling and the forward and reverse
 * solid-angle densities that the MIS quantities need (tech. rep. sec. 3-5).
 *
 * Conventions (those of the technical report and SmallVCM):
 * - "fix" is the direction from the vertex towards the previous vertex of the sub-path
 *   (where the path came from); "gen" is the direction being generated or connected.
 * - evaluate() returns f(fix, gen) of the non-specular lobes and both densities:
 *   direct = pdf of sampling gen given fix (the random walk's own direction), reverse = pdf
 *   of sampling fix given gen (the same edge walked the other way). Both include the lobe
 *   selection probability and the Russian-roulette continuation probability, so they are
 *   the exact densities of vf_bsdf_sample() for that direction.
 * - Specular lobes (mirror, smooth dielectric, smooth conductor) are Dirac deltas:
 *   evaluate() ignores them, sample() may pick them and then reports VF_BSDF_SPECULAR with
 *   pdf = probability of that choice (tech. rep. eq. 52). The rough lobes (GGX conductor
 *   and dielectric, the glTF base) are not deltas: connections and merging use them.
 * - Opaque lobes are two-sided: the shading frame faces the side the path arrives from.
 *   The dielectrics use the geometric orientation to tell entering from leaving.
 * - Transmission carries no 1/eta^2 factor here: sample() returns the factor of a light
 *   sub-path, which carries flux (conserved by refraction, up to Fresnel). Radiance is
 *   not: crossing from the side of fix into the side entered, a camera sub-path's
 *   throughput takes 1/eta^2 (Veach's thesis, sec. 5.2), which the renderer applies on
 *   VF_BSDF_REFRACTION. With camera and lights outside every dielectric a camera sub-path
 *   crosses each interface an even number of times and the factors cancel; a light inside
 *   glass (cornell-bulb) makes them count: 1.5^2 = 2.25 times too bright without them.
 *   The rough dielectric follows the same rule for sampled directions (VF_BSDF_REFRACTION,
 *   the light sub-path's factor), and since its transmission can also be evaluated (a
 *   connection or merge through rough glass), evaluate() gives a camera sub-path's vertex
 *   (vf_bsdf.radiance set) the radiance BTDF, Walter et al. 2007 eq. 21, and a light
 *   sub-path's vertex its adjoint, eta^2 times that: the two obey the generalised
 *   reciprocity f(i, o) / eta_o^2 = f(o, i) / eta_i^2 (Veach's thesis, sec. 5.2). */
#ifndef VF_BSDF_H
#define VF_BSDF_H

#include "../../common/vec3.h"
#include "../scene/material.h"
#include "microfacet.h"
#include "sampling.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

/* The lobes a material's BSDF is a sum of (worker/scene/material.h). A vertex samples them in this
 * order, the non-delta ones first: DIFFUSE, GLOSSY, ROUGH_CONDUCTOR, ROUGH_DIELECTRIC, BASE,
 * SHEEN, ROUGH_COAT, then MIRROR, DIELECTRIC, CONDUCTOR, COAT. The conductor and the
 * dielectric of a material are each either smooth (a delta) or rough, by its roughness;
 * ROUGH_CONDUCTOR is also the glTF model's specular layer, BASE its Lambertian base.
 *
 * The glTF model's layers (vf_bsdf.layered; bsdf.c, "the layers"), with the coat's own
 * normal n_c (its frame coat_frame) and the base's n (the shading frame):
 *   f = T(fix, gen) [S(fix, gen) f_gltf + sheen_color f_sheen / max(1, E(fix.n), E(gen.n))]
 *       + clearcoat F_c(fix.h_c) f_ggx(alpha_c; n_c)
 *   T = (1 - clearcoat F_c(|fix.n_c|)) (1 - clearcoat F_c(|gen.n_c|)),  F_c Schlick's of F0 0.04, F90 1
 *   S = min(1 - max_rgb(sheen_color) min(1, E(fix.n)), 1 - max_rgb(sheen_color) min(1, E(gen.n)))
 * f_sheen the Charlie sheen and E its albedo (worker/render/sheen.h), f_ggx D G2 / (4 |cos| |cos|)
 * with the height-correlated G2 (reflect_rough). KHR_materials_sheen's S and f_sheen as it
 * writes them wherever E <= 1; but the Charlie sheen with its fitted masking reflects more
 * than it receives towards grazing incidence at low roughness (E = 1.63 at 88.9 degrees for
 * sheen roughness 0.1, where S would turn negative): dividing by the larger albedo of the
 * two directions keeps f reciprocal and the sheen's albedo at most one, and the layered
 * albedo at most one where the base's is. KHR_materials_clearcoat weighs its layer by F_c(V.n_c) and the rest by 1 - clearcoat
 * F_c(V.n_c), of the view direction alone, which is not reciprocal: here the coat's Fresnel
 * is the microfacet's, F_c(fix.h_c) = F_c(gen.h_c) (the spec's own F_c(V.n_c) for a smooth
 * coat, and nearly so for the smooth coats its note has in mind), and what passes the coat
 * is attenuated on the way in and on the way out, which keeps the albedo at most one where
 * the layers below reflect at most one. The sheen is sampled by the cosine, the rough coat by
 * its visible normals in its frame. */
enum {
  VF_LOBE_DIFFUSE,
  VF_LOBE_GLOSSY,
  VF_LOBE_MIRROR,
  VF_LOBE_DIELECTRIC,
  VF_LOBE_CONDUCTOR,
  VF_LOBE_ROUGH_CONDUCTOR,
  VF_LOBE_ROUGH_DIELECTRIC,
  VF_LOBE_BASE,
  VF_LOBE_SHEEN,      /* glTF model, KHR_materials_sheen: the Charlie sheen over the base */
  VF_LOBE_ROUGH_COAT, /* glTF model, KHR_materials_clearcoat: the coat, rough ... */
  VF_LOBE_COAT,       /* ... or smooth (a delta) */
  VF_LOBE_COUNT
};
enum { VF_BSDF_SPECULAR = 1u, VF_BSDF_REFRACTION = 2u /* a dielectric transmitted */ };

typedef struct {
  /* What every BSDF reads, first: vf_bsdf_setup writes these, and a BSDF that is not
   * extended reads nothing after them (vf_bsdf_copy). */
  const vf_material *material; /* borrowed from the scene */
  vf_frame frame;              /* shading frame; z faces the side the path arrives from */
  vf_vec3 local_fix;           /* unit, towards the previous vertex, local (z > 0) */
  float lobe_probability[VF_LOBE_COUNT];
  float continuation;          /* Russian-roulette survival probability */
  float fresnel;               /* smooth dielectric reflection probability for this fix direction */
  float eta;                   /* ior of the side being entered over the side of fix */
  int is_delta;                /* only specular lobes: no connection or merging here */
  int extended;                /* a lobe after VF_LOBE_DIELECTRIC, or a phase function: bsdf.c
                                * evaluates and samples */
  int radiance;                /* a camera sub-path's vertex: see the top (0 after set-up; read
                                * only when extended) */
  int shading;                 /* shading normals (below; extended is then set) */
  int phase;                   /* a point in a medium (below; extended is then set) */
  vf_vec3 diffuse;             /* the diffuse lobe's albedo here (a texture may vary it) */
  /* Read only when extended. */
  int rough, fresnel_model;    /* a rough or base lobe; the conductors' VF_FRESNEL_* */
  float alpha, lambda_fix;     /* when rough: GGX alpha and Smith's Lambda(local_fix) */
  vf_vec3 f0, base;            /* glTF model: Schlick's F0 and the base's weight */
  float f90;                   /* glTF model: Schlick's F90 of the specular layer */
  float dielectric_f0_max, dielectric_f90; /* glTF model: the dielectric's, for the base's 1 - max_rgb F_d */
  /* Shading normals (vf_bsdf_setup_shading): the frame is the shading normal's, `geometric`
   * the unit geometric normal on the side of fix, fix_ratio |fix.n_shading| / |fix.n_geometric|. */
  vf_vec3 geometric;
  float fix_ratio;
  /* The glTF model's layers (see the top): the coat's weight (0: none),
   * alpha, frame (the shading frame unless vf_bsdf_set_coat_normal), fix in it and Smith's
   * Lambda there, its fold |fix.n_c| / |fix.n_g|, 1 - clearcoat F_c(|fix.n_c|); the sheen's
   * colour, roughness, alpha, max_rgb colour (0: none) and 1 - max_rgb E(fix.n). */
  int layered;
  float coat_weight, coat_alpha, coat_lambda_fix, coat_fix_ratio, coat_fix_transmit;
  vf_frame coat_frame;
  vf_vec3 coat_fix;
  vf_vec3 sheen_color;
  float sheen_roughness, sheen_alpha, sheen_max, sheen_fix_albedo, sheen_fix_scale;
  /* A point in a medium (vf_bsdf_setup_phase): f = sigma_s p_HG, the cosine 1, `geometric`
   * the unit world fix. */
  float phase_g;
  vf_vec3 sigma_s;
} vf_bsdf;

/* *dst = *src, the fields after `diffuse` only for an extended BSDF: the others never read
 * them, and the whole struct is three times the part they read (the glTF model's layers,
 * shading normals and the phase function came after it). For the renderer's queues of
 * BSDFs (merging queries, the fused pass's light vertices). */
static inline void vf_bsdf_copy(vf_bsdf *dst, const vf_bsdf *src) {
  if (src->extended) *dst = *src;
  else memcpy(dst, src, offsetof(vf_bsdf, diffuse) + sizeof src->diffuse);
}

/* What of a BSDF depends on its material only: the lobe selection probabilities (in
 * proportion to the lobes' albedos), the Russian-roulette continuation probability and
 * whether every lobe is specular. The renderer computes it once per material. */
typedef struct {
  float lobe_probability[VF_LOBE_COUNT];
  float continuation;
  int is_delta;
  int black; /* no lobe reflects anything: nothing scatters */
  int extended, rough, fresnel_model; /* as in vf_bsdf */
  float alpha;
  int layered; /* a glTF model with a sheen or a coat */
} vf_bsdf_lobes;

/* Fresnel reflectance of a smooth dielectric for cos_i (of the incident side, may be
 * negative meaning from inside) and eta = ior inside / outside. */
float vf_fresnel_dielectric(float cos_i, float eta);

void vf_bsdf_lobes_of(const vf_material *material, vf_bsdf_lobes *lobes);

/* The kinds of lobe a material has, VF_KIND_* bits: delta lobes (mirror, smooth dielectric
 * and conductor), glossy ones (Phong and the GGX lobes), diffuse ones (Lambertian, the glTF
 * base). `--algorithm auto` reads them (worker/render/vcm.c). */
enum { VF_KIND_SPECULAR = 1u, VF_KIND_GLOSSY = 2u, VF_KIND_DIFFUSE = 4u };
unsigned vf_material_kinds(const vf_material *material);

/* Sets up the BSDF at a vertex with geometric normal `normal` (unit) for a path arriving
 * from direction `world_fix` (unit, towards the previous vertex). Returns 0 when the vertex
 * cannot scatter (black material, fix in the tangent plane); 1 otherwise. */
int vf_bsdf_init(vf_bsdf *bsdf, const vf_material *material, vf_vec3 normal, vf_vec3 world_fix);

/* The extended lobes, out of line (bsdf.c): a material of the four lobes before them pays a
 * branch per call and runs the code it ran before they existed. vf_bsdf_setup_extended
 * completes vf_bsdf_setup (entering: fix on the front of the geometric normal);
 * vf_bsdf_evaluate_extended (with the BTDF of radiance or of flux) and
 * vf_bsdf_sample_extended are vf_bsdf_evaluate and vf_bsdf_sample for such a BSDF. */
#define VF_BSDF_UNLIKELY(x) __builtin_expect(!!(x), 0)
void vf_bsdf_setup_extended(vf_bsdf *b, const vf_bsdf_lobes *lobes, int entering);
vf_vec3 vf_bsdf_evaluate_extended(const vf_bsdf *b, vf_vec3 world_gen, float *cos_gen, float *direct_pdf_w,
                                  float *reverse_pdf_w, int radiance);
vf_vec3 vf_bsdf_sample_extended(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                                float *reverse_pdf_w, float *cos_gen, unsigned *event);

/* The same with the material's lobes computed beforehand (vf_bsdf_lobes_of); the result is
 * bit for bit that of vf_bsdf_init. Inline: the renderer sets up a BSDF at every vertex of
 * every sub-path and at light vertices it connects to. */
static inline int vf_bsdf_setup(vf_bsdf *b, const vf_material *m, const vf_bsdf_lobes *lobes, vf_vec3 normal,
                                vf_vec3 world_fix) {
  float cos_fix = vf_dot(normal, world_fix);
  if (!(fabsf(cos_fix) > 1e-7f) || lobes->black) return 0;
  /* The shading frame faces the arriving path, so local_fix.z > 0 always. */
  vf_vec3 n = cos_fix > 0.0f ? normal : vf_neg(normal);
  b->material = m;
  b->frame = vf_frame_from_normal(n);
  /* local_fix.z is |cos_fix| exactly (negating a vector negates each product and sum
   * exactly), so it is positive here and needs no test. */
  b->local_fix = vf_frame_to_local(&b->frame, world_fix);
  b->eta = 1.0f;
  b->fresnel = 0.0f;
  b->diffuse = m->diffuse;
  b->shading = 0;
  b->phase = 0;
  if (lobes->lobe_probability[VF_LOBE_DIELECTRIC] > 0.0f) {
    /* Arriving on the front of the geometric normal means entering the medium. */
    b->eta = cos_fix > 0.0f ? m->ior : 1.0f / m->ior;
    b->fresnel = vf_fresnel_dielectric(b->local_fix.z, b->eta);
  }
  /* memcpy: the compiler may not assume that b and lobes do not overlap otherwise */
  memcpy(b->lobe_probability, lobes->lobe_probability, sizeof b->lobe_probability);
  b->continuation = lobes->continuation;
  b->is_delta = lobes->is_delta;
  b->extended = lobes->extended;
  if (VF_BSDF_UNLIKELY(lobes->extended)) vf_bsdf_setup_extended(b, lobes, cos_fix > 0.0f);
  return 1;
}

/* vf_bsdf_setup at a vertex whose shading normal (unit, on the front of the geometric one
 * or flipped there) differs from its geometric normal: the lobes live in the shading
 * normal's frame, reflection and transmission are told apart by the geometric normal, and
 * a direction on one side of the geometric surface but the other of the shading one is
 * not scattered into (no light leaks through the surface). f is folded so that every
 * cosine the renderer sees is geometric (its area measure and MIS stay those of the
 * surface): a camera sub-path's vertex (radiance) returns f |gen.ns| / |gen.ng|, a light
 * sub-path's f |fix.ns| / |fix.ng|, so that f cos_gen is f_s |gen.ns| for radiance and
 * the adjoint f_s |fix.ns| |gen.ng| / |fix.ng| for importance (Veach's thesis, sec. 5.3,
 * eq. 5.19); both give the same value for the same vertex of a path whichever sub-path
 * reaches it, as the techniques of VCM need. Returns 0 where fix is below the shading
 * hemisphere. Out of line: bsdf.c. */
int vf_bsdf_setup_shading(vf_bsdf *b, const vf_material *m, const vf_bsdf_lobes *lobes, vf_vec3 geometric,
                          vf_vec3 shading, vf_vec3 world_fix);

/* The coat's own normal (unit, world) at a vertex set up by vf_bsdf_setup_shading whose
 * material has a clear coat: KHR_materials_clearcoat's coat is not turned by the base's
 * normal map, and has a normal map of its own. The coat's lobe lives in its frame and folds
 * its cosines as the base's do (|gen.n_c| / |gen.n_g| for radiance, |fix.n_c| / |fix.n_g|
 * for importance). world_fix as given to the set-up. Nothing for other BSDFs. */
void vf_bsdf_set_coat_normal(vf_bsdf *b, vf_vec3 coat_normal, vf_vec3 world_fix);

/* The "BSDF" of a point in a medium (worker/render/medium.h): scattering coefficient sigma_s
 * there (per unit length, the medium's times its density at the point), Henyey-Greenstein
 * asymmetry g, Russian-roulette survival `continuation`, for a path arriving from
 * world_fix. Its evaluate and sample are the phase function's, with cosine 1. */
void vf_bsdf_setup_phase(vf_bsdf *b, vf_vec3 sigma_s, float g, float continuation, vf_vec3 world_fix);

/* The mirror direction of local v about the shading normal. */
static inline vf_vec3 vf_bsdf_reflect_local(vf_vec3 v) { return vf_vec3_make(-v.x, -v.y, v.z); }

/* Diffuse and glossy (reflection only): f and both densities, without the continuation
 * probability, added to *f, *direct and *reverse for local gen. */
static inline void vf_bsdf_smooth_lobes(const vf_bsdf *b, vf_vec3 gen, vf_vec3 *f, float *direct, float *reverse) {
  if (!(gen.z > 0.0f)) return;
  float pd = b->lobe_probability[VF_LOBE_DIFFUSE];
  if (pd > 0.0f) {
    *f = vf_add(*f, vf_scale(b->diffuse, VF_INV_PI));
    *direct += pd * gen.z * VF_INV_PI;
    *reverse += pd * b->local_fix.z * VF_INV_PI;
  }
  float pg = b->lobe_probability[VF_LOBE_GLOSSY];
  if (pg > 0.0f) {
    float n = b->material->phong_exponent;
    /* cos of the angle between gen and fix's mirror direction; symmetric in fix and gen. */
    const vf_vec3 fix = b->local_fix;
    float cos_a = vf_dot(vf_bsdf_reflect_local(fix), gen);
    if (cos_a > 0.0f) {
      float lobe = vf_phong_power(cos_a, n);
      *f = vf_add(*f, vf_scale(b->material->glossy, (n + 2.0f) * (0.5f * VF_INV_PI) * lobe));
      float p = pg * (n + 1.0f) * (0.5f * VF_INV_PI) * lobe;
      *direct += p;
      *reverse += p;
    }
  }
}

/* vf_bsdf_evaluate for a BSDF of the four older lobes alone (not extended). */
static inline vf_vec3 vf_bsdf_evaluate_smooth(const vf_bsdf *b, vf_vec3 world_gen, float *cos_gen, float *direct_pdf_w,
                                              float *reverse_pdf_w) {
  vf_vec3 gen = vf_frame_to_local(&b->frame, world_gen);
  vf_vec3 f = vf_vec3_splat(0.0f);
  float dpdf = 0.0f, rpdf = 0.0f;
  vf_bsdf_smooth_lobes(b, gen, &f, &dpdf, &rpdf);
  if (cos_gen) *cos_gen = fabsf(gen.z);
  if (direct_pdf_w) *direct_pdf_w = dpdf * b->continuation;
  if (reverse_pdf_w) *reverse_pdf_w = rpdf * b->continuation;
  return f;
}

/* f of the non-specular lobes for gen (unit, world); |cos| of gen against the shading
 * normal into *cos_gen; densities as described above (either may be NULL). Zero when gen is
 * not reachable by the non-specular lobes. A transmission's f is that of the quantity
 * vf_bsdf.radiance says the sub-path carries (see the top).
 * Inline because the renderer calls it about five times per camera vertex: out of line,
 * each call spilled its operands around powf and returned through memory, and the NULL
 * checks of the out-parameters are resolved at compile time in every caller. */
static inline vf_vec3 vf_bsdf_evaluate(const vf_bsdf *b, vf_vec3 world_gen, float *cos_gen, float *direct_pdf_w,
                                       float *reverse_pdf_w) {
  if (VF_BSDF_UNLIKELY(b->extended))
    return vf_bsdf_evaluate_extended(b, world_gen, cos_gen, direct_pdf_w, reverse_pdf_w, b->radiance);
  return vf_bsdf_evaluate_smooth(b, world_gen, cos_gen, direct_pdf_w, reverse_pdf_w);
}

/* A local direction of the diffuse (u < its probability) or the glossy lobe. */
static inline vf_vec3 vf_bsdf_sample_smooth(const vf_bsdf *b, float u, const float rnd[3]) {
  if (u < b->lobe_probability[VF_LOBE_DIFFUSE]) return vf_sample_cosine_hemisphere(rnd[0], rnd[1], NULL);
  vf_vec3 axis = vf_bsdf_reflect_local(b->local_fix);
  vf_frame lobe = vf_frame_from_normal(axis);
  return vf_frame_to_world(&lobe, vf_sample_power_cosine(rnd[0], rnd[1], b->material->phong_exponent));
}

/* vf_bsdf_sample's results for a non-specular direction from its evaluation (f and the
 * densities d, r with the continuation, c = |cos|); zero when the density is. */
static inline vf_vec3 vf_bsdf_sampled(vf_vec3 f, float d, float r, float c, float *pdf_w, float *reverse_pdf_w,
                                      float *cos_gen) {
  if (!(d > 0.0f)) return vf_vec3_splat(0.0f);
  *pdf_w = d;
  *reverse_pdf_w = r;
  *cos_gen = c;
  return f;
}

/* The delta lobe chosen by u (what is left of the choice after the non-delta lobes):
 * vf_bsdf_sample's results. The mirror, or the smooth dielectric. */
static inline vf_vec3 vf_bsdf_sample_delta(const vf_bsdf *b, float u, vf_vec3 *world_gen, float *pdf_w,
                                           float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  const float *p = b->lobe_probability;
  vf_vec3 gen;
  *event = VF_BSDF_SPECULAR;
  float choice_pdf;
  vf_vec3 weight;
  if (u < p[VF_LOBE_MIRROR] || p[VF_LOBE_DIELECTRIC] == 0.0f) {
    gen = vf_bsdf_reflect_local(b->local_fix);
    choice_pdf = p[VF_LOBE_MIRROR];
    weight = b->material->mirror;
  } else {
    /* Within the dielectric lobe, reflect with probability F: the throughput factor is
     * then tint * F / (p_lobe * F), the same for refraction with 1 - F. */
    u = (u - p[VF_LOBE_MIRROR]) / p[VF_LOBE_DIELECTRIC];
    const vf_vec3 fix = b->local_fix;
    if (u < b->fresnel) {
      gen = vf_bsdf_reflect_local(fix);
      choice_pdf = p[VF_LOBE_DIELECTRIC] * b->fresnel;
      weight = vf_scale(b->material->dielectric, b->fresnel);
    } else {
      double eta = b->eta, ci = fix.z;
      double cos_t2 = 1.0 - (1.0 - ci * ci) / (eta * eta);
      /* fmax(0.0, cos_t2) without its libm call (see vf_fmaxf_zero). */
      float cos_t = (float)sqrt(cos_t2 >= 0.0 ? cos_t2 : 0.0);
      gen = vf_vec3_make(-fix.x / b->eta, -fix.y / b->eta, -cos_t);
      *event |= VF_BSDF_REFRACTION;
      choice_pdf = p[VF_LOBE_DIELECTRIC] * (1.0f - b->fresnel);
      weight = vf_scale(b->material->dielectric, 1.0f - b->fresnel);
    }
  }
  if (!(choice_pdf > 0.0f) || gen.z == 0.0f) return vf_vec3_splat(0.0f);
  float c = fabsf(gen.z);
  *world_gen = vf_frame_to_world(&b->frame, gen);
  *pdf_w = choice_pdf * b->continuation;
  *reverse_pdf_w = *pdf_w;
  *cos_gen = c;
  /* f such that f * cos / pdf = weight / (choice_pdf * continuation). */
  return vf_scale(weight, 1.0f / c);
}

/* Samples gen with three uniform numbers. Returns f (for specular lobes: the weight such that
 * f * cos / pdf is the throughput factor; for a transmission a light sub-path's f whatever
 * vf_bsdf.radiance says, see the top), and writes gen, its |cos|, the direct and reverse
 * densities (with the continuation probability; equal for a specular choice) and
 * VF_BSDF_SPECULAR when a delta lobe was chosen (and VF_BSDF_REFRACTION when a dielectric
 * transmitted, entering the side of ior ratio bsdf->eta). Returns zero (and nothing else is
 * meaningful) when the sample failed. The caller plays Russian roulette with
 * vf_bsdf.continuation before calling. */
static inline vf_vec3 vf_bsdf_sample(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                                     float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  if (VF_BSDF_UNLIKELY(b->extended)) return vf_bsdf_sample_extended(b, rnd, world_gen, pdf_w, reverse_pdf_w, cos_gen, event);
  const float *p = b->lobe_probability;
  float u = rnd[2];
  *event = 0;
  if (u < p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY]) {
    vf_vec3 gen = vf_bsdf_sample_smooth(b, u, rnd);
    /* Evaluate the direction that is returned, after its round trip through the world
     * frame, so that sample and evaluate agree even for a Phong exponent of 1e5, where
     * cos^n magnifies the frames' rounding 2n times. */
    *world_gen = vf_frame_to_world(&b->frame, gen);
    float d, r, c;
    vf_vec3 f = vf_bsdf_evaluate_smooth(b, *world_gen, &c, &d, &r);
    return vf_bsdf_sampled(f, d, r, c, pdf_w, reverse_pdf_w, cos_gen);
  }
  return vf_bsdf_sample_delta(b, u - (p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY]), world_gen, pdf_w, reverse_pdf_w,
                              cos_gen, event);
}

#endif
