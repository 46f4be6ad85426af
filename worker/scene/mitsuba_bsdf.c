/* Mitsuba 3 BSDFs and textures as vcmfarm materials (mitsuba_bsdf.h). The mapping and
 * every approximation are tabled in docs/SCENES.md, "Mitsuba 3 scenes". */
#include "mitsuba_bsdf.h"

#include "../../common/error.h"
#include "texture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

/* Mitsuba's named conductors as RGB eta + i k: measured spectra (the data Mitsuba ships)
 * integrated against linear sRGB, as tabulated by the Tungsten renderer
 * (ComplexIorData.hpp). Mitsuba renders the spectra; RGB is what vcmfarm can hold. */
static const struct {
  const char *name;
  double eta[3], k[3];
} conductors[] = {
    {"Ag", {0.1552646489, 0.1167232965, 0.1383806959}, {4.8283433224, 3.1222459278, 2.1469504455}},
    {"Al", {1.6574599595, 0.8803689579, 0.5212287346}, {9.2238691996, 6.2695232477, 4.8370012281}},
    {"Au", {0.1431189557, 0.3749570432, 1.4424785571}, {3.9831604247, 2.3857207478, 1.6032152899}},
    {"Cr", {4.3696828663, 2.9167024892, 1.6547005413}, {5.2064337956, 4.2313645277, 3.7549467933}},
    {"Cu", {0.2004376970, 0.9240334304, 1.1022119527}, {3.9129485033, 2.4528477015, 2.1421879552}},
};

/* Mitsuba's named indices of refraction (include/mitsuba/render/ior.h: Hecht, Optics). */
static const struct {
  const char *name;
  double ior;
} iors[] = {
    {"vacuum", 1.0},          {"helium", 1.000036},      {"hydrogen", 1.000132},       {"air", 1.000277},
    {"carbon dioxide", 1.00045}, {"water", 1.3330},      {"acetone", 1.36},            {"ethanol", 1.361},
    {"carbon tetrachloride", 1.461}, {"glycerol", 1.4729}, {"benzene", 1.501},         {"silicone oil", 1.52045},
    {"bromine", 1.661},       {"water ice", 1.31},       {"fused quartz", 1.458},      {"pyrex", 1.470},
    {"acrylic glass", 1.49},  {"polypropylene", 1.49},   {"bk7", 1.5046},              {"sodium chloride", 1.544},
    {"amber", 1.55},          {"pet", 1.5750},           {"diamond", 2.419},
};

static int add_vec3(cJSON *o, const char *key, vf_vec3 v) {
  cJSON *a = mts_vec3_json(v);
  if (a == NULL || !cJSON_AddItemToObject(o, key, a)) {
    cJSON_Delete(a);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  return VF_OK;
}

static int add_number(cJSON *o, const char *key, double v) {
  return cJSON_AddNumberToObject(o, key, v) ? VF_OK : vf_error_set(VF_ENOMEM, "out of memory");
}

/* An index of refraction: a <float> or one of Mitsuba's names. */
static int ior_property(mts_ctx *c, vf_xml_node *e, const char *name, double def, double *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0 || p == NULL) return err;
  const char *v = vf_xml_attr(p, "value");
  if (strcmp(p->name, "string") == 0 && v != NULL) {
    for (size_t i = 0; i < sizeof iors / sizeof iors[0]; i++)
      if (strcasecmp(v, iors[i].name) == 0) return *out = iors[i].ior, VF_OK;
    return mts_fail(p, "'%s' is not one of Mitsuba's named indices of refraction", v);
  }
  if ((err = mts_float(c, e, name, def, out)) < 0) return err;
  if (!(*out > 0)) return mts_fail(p, "an index of refraction must be > 0, found %g", *out);
  return VF_OK;
}

int mts_bitmap(mts_ctx *c, vf_xml_node *t, int color, cJSON **out) {
  *out = NULL;
  const char *type = vf_xml_attr(t, "type");
  if (type == NULL || strcmp(type, "bitmap") != 0) return 0;
  t->used = 1;
  const char *file, *wrap, *filter;
  int raw, err;
  if ((err = mts_string(c, t, "filename", NULL, &file)) < 0) return err;
  if (file == NULL) return mts_fail(t, "has no filename");
  char path[8192];
  snprintf(path, sizeof path, "%s%s%s", file[0] == '/' ? "" : c->dir, file[0] == '/' ? "" : "/", file);
  FILE *f = fopen(path, "rb");
  if (f == NULL) {
    mts_fail(t, "cannot open '%s': %s", file, strerror(errno));
    char detail[1024];
    snprintf(detail, sizeof detail, "%s", vf_error_detail(VF_ESCENE));
    return vf_error_set(VF_ENOENT, "%s", detail);
  }
  fclose(f);
  if ((err = mts_string(c, t, "wrap_mode", "repeat", &wrap)) < 0 || (err = mts_bool(c, t, "raw", 0, &raw)) < 0 ||
      (err = mts_string(c, t, "filter_type", "bilinear", &filter)) < 0)
    return err;
  if (strcmp(wrap, "repeat") != 0 && strcmp(wrap, "mirror") != 0 && strcmp(wrap, "clamp") != 0)
    return mts_fail(t, "wrap_mode '%s' is not repeat, mirror or clamp", wrap);
  if (strcmp(filter, "bilinear") != 0 && (err = mts_note(c, t, "filter_type '%s': filtered bilinearly", filter)) < 0)
    return err;
  /* vcmfarm decodes the colour slots' 8-bit texels from sRGB, as Mitsuba does unless raw. */
  if (color && raw && (err = mts_note(c, t, "raw: an 8-bit image in a colour slot is still decoded from sRGB")) < 0) return err;
  cJSON *o = cJSON_CreateObject();
  if (o == NULL || !cJSON_AddStringToObject(o, "file", file) || !cJSON_AddStringToObject(o, "wrap", wrap)) {
    cJSON_Delete(o);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  if ((err = mts_note_unused(c, t)) < 0) {
    cJSON_Delete(o);
    return err;
  }
  *out = o;
  return 1;
}

/* A colour slot: an RGB into `key`, or a bitmap into `texture_key` (a checkerboard as the
 * mean of its colours, noted). */
static int color_slot(mts_ctx *c, vf_xml_node *e, const char *name, vf_vec3 def, cJSON *m, const char *key,
                      const char *texture_key) {
  vf_vec3 v;
  vf_xml_node *t;
  int got = mts_color(c, e, name, def, &v, &t), err;
  if (got < 0) return got;
  if (got != 2) return add_vec3(m, key, v);
  cJSON *tex;
  if ((err = mts_bitmap(c, t, 1, &tex)) < 0) return err;
  if (err == 1) return cJSON_AddItemToObject(m, texture_key, tex) ? VF_OK : (cJSON_Delete(tex), vf_error_set(VF_ENOMEM, "out of memory"));
  const char *type = vf_xml_attr(t, "type");
  t->used = 1;
  if (type != NULL && strcmp(type, "checkerboard") == 0) {
    vf_vec3 c0, c1;
    vf_xml_node *sub;
    if ((err = mts_color(c, t, "color0", vf_vec3_splat(0.4f), &c0, &sub)) < 0 ||
        (err = mts_color(c, t, "color1", vf_vec3_splat(0.2f), &c1, &sub)) < 0)
      return err;
    vf_affine ignored;
    if ((err = mts_transform(c, t, "to_uv", &ignored)) < 0) return err;
    vf_vec3 mean = vf_scale(vf_add(c0, c1), 0.5f);
    if ((err = mts_note(c, t, "checkerboard is rendered as the mean of its colours (%g, %g, %g)", mean.x, mean.y,
                        mean.z)) < 0)
      return err;
    return add_vec3(m, key, mean);
  }
  if ((err = mts_note(c, t, "texture '%s' is not supported: the default value is used", type ? type : "?")) < 0)
    return err;
  return add_vec3(m, key, def);
}

/* Mitsuba's alpha (GGX or Beckmann width) as vcmfarm's roughness, alpha = roughness^2
 * (worker/render/microfacet.h, vf_ggx_alpha). */
static int roughness(mts_ctx *c, vf_xml_node *b, cJSON *m) {
  const char *distribution;
  double alpha, au, av;
  int err, has_u, has_v;
  if ((err = mts_string(c, b, "distribution", "beckmann", &distribution)) < 0 ||
      (err = mts_float(c, b, "alpha", 0.1, &alpha)) < 0 || (has_u = mts_float(c, b, "alpha_u", alpha, &au)) < 0 ||
      (has_v = mts_float(c, b, "alpha_v", alpha, &av)) < 0)
    return err < 0 ? err : has_u < 0 ? has_u : has_v;
  if (strcmp(distribution, "beckmann") == 0) {
    if ((err = mts_note(c, b, "the Beckmann distribution is rendered as GGX of the same alpha")) < 0) return err;
  } else if (strcmp(distribution, "ggx") != 0) {
    return mts_fail(b, "distribution '%s' is neither beckmann nor ggx", distribution);
  }
  if (has_u || has_v) {
    alpha = sqrt(au * av);
    if (au != av && (err = mts_note(c, b, "anisotropic alpha_u %g, alpha_v %g: isotropic alpha %g", au, av, alpha)) < 0)
      return err;
  }
  if (!(alpha >= 0)) return mts_fail(b, "alpha must be >= 0, found %g", alpha);
  if (alpha > 1) {
    if ((err = mts_note(c, b, "alpha %g is clamped to 1 (vcmfarm's roughness 1)", alpha)) < 0) return err;
    alpha = 1;
  }
  return add_number(m, "roughness", sqrt(alpha));
}

/* A conductor's textured eta or k: vcmfarm's conductors take one eta and one k per
 * material, so a bitmap is rendered as the mean of its texels (as Mitsuba reads them: 8-bit
 * texels decoded from sRGB unless raw, EXR as stored), noted; another texture is refused. */
static int ior_bitmap(mts_ctx *c, vf_xml_node *t, const char *name, vf_vec3 *value) {
  cJSON *o;
  int err = mts_bitmap(c, t, 0, &o);
  if (err < 0) return err;
  if (err == 0) {
    const char *type = vf_xml_attr(t, "type");
    return mts_fail(t, "a textured %s must be a bitmap, not '%s'", name, type ? type : "?");
  }
  const char *file = cJSON_GetObjectItemCaseSensitive(o, "file")->valuestring;
  char path[8192];
  snprintf(path, sizeof path, "%s%s%s", file[0] == '/' ? "" : c->dir, file[0] == '/' ? "" : "/", file);
  int raw;
  vf_texture tex;
  memset(&tex, 0, sizeof tex);
  if ((err = mts_bool(c, t, "raw", 0, &raw)) < 0 || (err = vf_texture_read(path, file, &tex)) < 0) {
    cJSON_Delete(o);
    return err == VF_ENOMEM ? err : mts_fail(t, "cannot read '%s' as an image", file);
  }
  double sum[3] = {0, 0, 0};
  size_t n = (size_t)tex.width * tex.height;
  int colour = tex.channels >= 3 ? 3 : 1;
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) {
      size_t at = i * (size_t)tex.channels + (size_t)(colour == 3 ? k : 0);
      double v = tex.is_float ? ((const float *)tex.texels)[at] : ((const uint8_t *)tex.texels)[at] / 255.0;
      if (!tex.is_float && !raw) v = v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
      sum[k] += v;
    }
  vf_texture_release(&tex);
  cJSON_Delete(o);
  *value = vf_vec3_make((float)(sum[0] / n), (float)(sum[1] / n), (float)(sum[2] / n));
  if (!(value->x >= 0 && value->y >= 0 && value->z >= 0 && isfinite(value->x + value->y + value->z)))
    return mts_fail(t, "the mean of '%s' is not a finite non-negative %s", file, name);
  return mts_note(c, t, "a textured %s is rendered as the mean of its texels (%g, %g, %g): vcmfarm's conductors take "
                        "one eta and one k per material", name, value->x, value->y, value->z);
}

static int conductor(mts_ctx *c, vf_xml_node *b, cJSON *m, int rough) {
  const char *material;
  vf_vec3 eta, k, tint;
  vf_xml_node *t;
  int err, has_eta, has_k;
  if ((err = mts_string(c, b, "material", "none", &material)) < 0) return err;
  if ((has_eta = mts_color(c, b, "eta", vf_vec3_splat(0), &eta, &t)) < 0) return has_eta;
  if (has_eta == 2 && (err = ior_bitmap(c, t, "eta", &eta)) < 0) return err;
  if ((has_k = mts_color(c, b, "k", vf_vec3_splat(1), &k, &t)) < 0) return has_k;
  if (has_k == 2 && (err = ior_bitmap(c, t, "k", &k)) < 0) return err;
  if ((err = mts_color(c, b, "specular_reflectance", vf_vec3_splat(1), &tint, &t)) < 0) return err;
  if (err == 2) return mts_fail(t, "a textured specular_reflectance is not supported");
  if ((err = add_vec3(m, "conductor", tint)) < 0) return err;
  if (!has_eta && !has_k) {
    if (strcmp(material, "none") == 0) return rough ? roughness(c, b, m) : VF_OK; /* Fresnel 1 */
    size_t i = 0;
    while (i < sizeof conductors / sizeof conductors[0] && strcmp(conductors[i].name, material) != 0) i++;
    if (i == sizeof conductors / sizeof conductors[0])
      return mts_fail(b, "conductor material '%s' is not in vcmfarm's table (none, Ag, Al, Au, Cr, Cu): give eta and k",
                      material);
    eta = vf_vec3_make((float)conductors[i].eta[0], (float)conductors[i].eta[1], (float)conductors[i].eta[2]);
    k = vf_vec3_make((float)conductors[i].k[0], (float)conductors[i].k[1], (float)conductors[i].k[2]);
  } else if (strcmp(material, "none") != 0) {
    return mts_fail(b, "give a material or eta and k, not both");
  }
  if ((err = add_vec3(m, "eta", eta)) < 0 || (err = add_vec3(m, "k", k)) < 0) return err;
  return rough ? roughness(c, b, m) : VF_OK;
}

static int dielectric(mts_ctx *c, vf_xml_node *b, cJSON *m, const char *type) {
  double int_ior, ext_ior;
  vf_vec3 r, t;
  vf_xml_node *tex;
  int err;
  if ((err = ior_property(c, b, "int_ior", 1.5046, &int_ior)) < 0 ||
      (err = ior_property(c, b, "ext_ior", 1.000277, &ext_ior)) < 0)
    return err;
  if ((err = mts_color(c, b, "specular_reflectance", vf_vec3_splat(1), &r, &tex)) < 0) return err;
  if (err == 2) return mts_fail(tex, "a textured specular_reflectance is not supported");
  if ((err = mts_color(c, b, "specular_transmittance", vf_vec3_splat(1), &t, &tex)) < 0) return err;
  if (err == 2) return mts_fail(tex, "a textured specular_transmittance is not supported");
  if ((r.x != t.x || r.y != t.y || r.z != t.z) &&
      (err = mts_note(c, b, "specular_reflectance differs from specular_transmittance: both are the transmittance")) < 0)
    return err;
  if (strcmp(type, "thindielectric") == 0) {
    /* A sheet: two interfaces with inter-reflection reflect R' = 2R / (1 + R) of what
     * arrives and pass the rest straight through. vcmfarm has no sheet: a mirror of R' at
     * normal incidence beside a dielectric of ior 1 (straight transmission) of 1 - R'. */
    double eta = int_ior / ext_ior, r0 = (eta - 1) * (eta - 1) / ((eta + 1) * (eta + 1)), rs = 2 * r0 / (1 + r0);
    if ((err = add_vec3(m, "mirror", vf_scale(t, (float)rs))) < 0 || (err = add_vec3(m, "dielectric", vf_scale(t, (float)(1 - rs)))) < 0 ||
        (err = add_number(m, "ior", 1.0)) < 0)
      return err;
    return mts_note(c, b, "thindielectric is approximated: a mirror of the sheet's normal-incidence reflectance %.4f "
                    "and straight transmission of the rest (no angular Fresnel)", rs);
  }
  if ((err = add_vec3(m, "dielectric", t)) < 0 || (err = add_number(m, "ior", int_ior / ext_ior)) < 0) return err;
  return strcmp(type, "roughdielectric") == 0 ? roughness(c, b, m) : VF_OK;
}

/* plastic and roughplastic: glTF's dielectric base (metallic 0), whose specular layer has
 * F0 = 0.04 (ior 1.5) over a Lambertian base weighted by 1 - F. */
static int plastic(mts_ctx *c, vf_xml_node *b, cJSON *m, int rough) {
  double int_ior, ext_ior;
  int err;
  if ((err = ior_property(c, b, "int_ior", 1.49, &int_ior)) < 0 || (err = ior_property(c, b, "ext_ior", 1.000277, &ext_ior)) < 0)
    return err;
  if ((err = color_slot(c, b, "diffuse_reflectance", vf_vec3_splat(0.5f), m, "base_color", "base_color_texture")) < 0 ||
      (err = add_number(m, "metallic", 0)) < 0)
    return err;
  vf_vec3 spec;
  vf_xml_node *t;
  int nonlinear;
  if ((err = mts_color(c, b, "specular_reflectance", vf_vec3_splat(1), &spec, &t)) < 0 ||
      (err = mts_bool(c, b, "nonlinear", 0, &nonlinear)) < 0)
    return err;
  if (rough) {
    if ((err = roughness(c, b, m)) < 0) return err;
  } else if ((err = add_number(m, "roughness", 0)) < 0) {
    return err;
  }
  return mts_note(c, b, "%s is approximated by glTF's dielectric base: F0 0.04 (ior 1.5; the file's %.4g), no internal "
                  "scattering%s", vf_xml_attr(b, "type"), int_ior / ext_ior,
                  spec.x != 1 || spec.y != 1 || spec.z != 1 || nonlinear ? ", specular_reflectance and nonlinear ignored" : "");
}

static int principled(mts_ctx *c, vf_xml_node *b, cJSON *m) {
  double metallic, rough;
  int err;
  if ((err = color_slot(c, b, "base_color", vf_vec3_splat(0.5f), m, "base_color", "base_color_texture")) < 0 ||
      (err = mts_float(c, b, "metallic", 0, &metallic)) < 0 || (err = mts_float(c, b, "roughness", 0.5, &rough)) < 0)
    return err;
  if (!(metallic >= 0 && metallic <= 1 && rough >= 0 && rough <= 1))
    return mts_fail(b, "metallic and roughness must lie in [0, 1]");
  if ((err = add_number(m, "metallic", metallic)) < 0 || (err = add_number(m, "roughness", rough)) < 0) return err;
  if ((err = mts_note(c, b, "principled is approximated by glTF's metallic-roughness model of its base_color, metallic "
                      "and roughness")) < 0)
    return err;
  /* Its clear coat: Disney's secondary lobe, 0.25 clearcoat F_c D G of a GTR1 distribution
   * of alpha lerp(0.1, 0.001, clearcoat_gloss), added over the rest; KHR_materials_clearcoat's
   * coat (the JSON's clearcoat fields) of that weight and a GGX of that alpha is the nearest
   * vcmfarm has, a layer that also dims what lies beneath by its Fresnel. */
  double coat, gloss;
  vf_xml_node *t;
  vf_vec3 coat_rgb;
  if ((err = mts_color(c, b, "clearcoat", vf_vec3_splat(0), &coat_rgb, &t)) < 0) return err;
  if (err == 2) return mts_fail(t, "a textured clearcoat is not supported");
  coat = coat_rgb.x;
  if ((err = mts_float(c, b, "clearcoat_gloss", 0, &gloss)) < 0) return err;
  if (!(coat >= 0 && coat <= 1 && gloss >= 0 && gloss <= 1)) return mts_fail(b, "clearcoat and clearcoat_gloss must lie in [0, 1]");
  if (!(coat > 0)) return VF_OK;
  double alpha = 0.1 + (0.001 - 0.1) * gloss;
  if ((err = add_number(m, "clearcoat", 0.25 * coat)) < 0 || (err = add_number(m, "clearcoat_roughness", sqrt(alpha))) < 0)
    return err;
  return mts_note(c, b, "principled's clear coat (GTR1, weight 0.25 clearcoat, added over the rest) is approximated by "
                  "KHR_materials_clearcoat's GGX coat of weight %g and alpha %g, layered over the rest", 0.25 * coat, alpha);
}

/* The lobes of b (and of the BSDF it wraps) into m. */
static int build(mts_ctx *c, vf_xml_node *b, cJSON *m, int depth, int *twosided) {
  const char *type = vf_xml_attr(b, "type");
  int err;
  if (depth > 8) return mts_fail(b, "BSDFs nest more than 8 deep");
  b->used = 1;
  if (type == NULL) return mts_fail(b, "has no type");
  if (strcmp(type, "twosided") == 0 || strcmp(type, "normalmap") == 0 || strcmp(type, "mask") == 0 ||
      strcmp(type, "bumpmap") == 0) {
    vf_xml_node *inner[2] = {NULL, NULL};
    int n = 0;
    for (int i = 0; i < b->num_children; i++) {
      vf_xml_node *ch = b->children[i];
      vf_xml_node *d = strcmp(ch->name, "bsdf") == 0 || strcmp(ch->name, "ref") == 0 ? mts_deref(c, ch, &err) : NULL;
      if (d == NULL && strcmp(ch->name, "ref") == 0) return err;
      if (d != NULL && strcmp(d->name, "bsdf") == 0 && n < 2) ch->used = 1, inner[n++] = d;
    }
    if (n == 0) return mts_fail(b, "wraps no <bsdf>");
    if (strcmp(type, "twosided") == 0) {
      *twosided = 1;
      if (n == 2 && (err = mts_note(c, b, "a second BSDF for the back side is not supported: the front's is used on both")) < 0)
        return err;
    } else if (strcmp(type, "normalmap") == 0) {
      int got;
      vf_xml_node *t = mts_child(c, b, "normalmap", &got);
      cJSON *tex;
      if (got < 0) return got;
      if (t == NULL) return mts_fail(b, "has no normalmap texture");
      if ((err = mts_bitmap(c, t, 0, &tex)) < 0) return err;
      if (err == 0) return mts_fail(t, "a normal map must be a bitmap");
      if (!cJSON_AddItemToObject(m, "normal_texture", tex)) return cJSON_Delete(tex), vf_error_set(VF_ENOMEM, "out of memory");
      if ((err = mts_note(c, b, "the normal map is read in vcmfarm's tangent frame (bitangent towards decreasing t; "
                          "Mitsuba's is n x dp/du): see docs/SCENES.md")) < 0)
        return err;
    } else if (strcmp(type, "bumpmap") == 0) {
      for (int i = 0; i < b->num_children; i++)
        if (strcmp(b->children[i]->name, "texture") == 0) b->children[i]->used = 1;
      if ((err = mts_note(c, b, "bumpmap is not supported: the wrapped BSDF is rendered without it")) < 0) return err;
    } else { /* mask: opacity as a cut-out */
      double opacity;
      vf_vec3 ov;
      vf_xml_node *t;
      if ((err = mts_color(c, b, "opacity", vf_vec3_splat(0.5f), &ov, &t)) < 0) return err;
      if (err == 2) {
        cJSON *tex;
        if ((err = mts_bitmap(c, t, 0, &tex)) < 0) return err;
        if (err == 0) return mts_fail(t, "an opacity texture must be a bitmap");
        if (!cJSON_AddItemToObject(m, "alpha_texture", tex)) return cJSON_Delete(tex), vf_error_set(VF_ENOMEM, "out of memory");
        if ((err = add_number(m, "alpha_channel", 0)) < 0) return err;
        opacity = 1;
      } else {
        opacity = (ov.x + ov.y + ov.z) / 3;
      }
      if (!(opacity >= 0 && opacity <= 1)) return mts_fail(b, "opacity must lie in [0, 1], found %g", opacity);
      if ((err = add_number(m, "alpha", opacity)) < 0 || (err = add_number(m, "alpha_cutoff", 0.5)) < 0) return err;
      if ((err = mts_note(c, b, "mask: opacity (the first channel of a texture) is a cut-out at 0.5, where Mitsuba "
                          "blends stochastically")) < 0)
        return err;
    }
    if ((err = build(c, inner[0], m, depth + 1, twosided)) < 0) return err;
    return mts_note_unused(c, b);
  }
  if (strcmp(type, "diffuse") == 0) err = color_slot(c, b, "reflectance", vf_vec3_splat(0.5f), m, "diffuse", "diffuse_texture");
  else if (strcmp(type, "conductor") == 0) err = conductor(c, b, m, 0);
  else if (strcmp(type, "roughconductor") == 0) err = conductor(c, b, m, 1);
  else if (strcmp(type, "dielectric") == 0 || strcmp(type, "roughdielectric") == 0 || strcmp(type, "thindielectric") == 0)
    err = dielectric(c, b, m, type);
  else if (strcmp(type, "plastic") == 0) err = plastic(c, b, m, 0);
  else if (strcmp(type, "roughplastic") == 0) err = plastic(c, b, m, 1);
  else if (strcmp(type, "principled") == 0) err = principled(c, b, m);
  else if (strcmp(type, "null") == 0) {
    /* Invisible: a dielectric of ior 1 passes every ray straight on. */
    if ((err = add_vec3(m, "dielectric", vf_vec3_splat(1))) < 0 || (err = add_number(m, "ior", 1)) < 0) return err;
    return mts_note(c, b, "null is a dielectric of ior 1 (rays pass straight on; each crossing is a path segment)");
  } else {
    for (int i = 0; i < b->num_children; i++) b->children[i]->used = 1;
    if ((err = mts_note(c, b, "bsdf '%s' is not supported: rendered as diffuse grey 0.5", type)) < 0) return err;
    return add_vec3(m, "diffuse", vf_vec3_splat(0.5f));
  }
  if (err < 0) return err;
  /* Opaque Mitsuba BSDFs are black from behind unless wrapped in twosided; vcmfarm's
   * opaque lobes scatter on both sides. */
  if (!*twosided && strstr(type, "dielectric") == NULL &&
      (err = mts_note(c, b, "not wrapped in twosided: Mitsuba's back side is black, vcmfarm's scatters as the front")) < 0)
    return err;
  return mts_note_unused(c, b);
}

/* The albedo-sum rule of docs/SCENES.md (materials), checked here to name the element. */
static int check_albedo(const vf_xml_node *b, const cJSON *m) {
  static const char *const lobes[] = {"diffuse", "mirror", "dielectric", "conductor", "base_color"};
  double sum[3] = {0, 0, 0};
  for (size_t i = 0; i < sizeof lobes / sizeof lobes[0]; i++) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, lobes[i]);
    for (int k = 0; v != NULL && k < 3; k++) {
      double x = cJSON_GetArrayItem(v, k)->valuedouble;
      if (x < 0) return mts_fail(b, "%s is negative (%g)", lobes[i], x);
      sum[k] += x;
    }
  }
  for (int k = 0; k < 3; k++)
    if (sum[k] > 1 + 1e-5)
      return mts_fail(b, "reflects more than it receives (channel %c: %g): vcmfarm refuses albedos above 1", "rgb"[k], sum[k]);
  return VF_OK;
}

int mts_material(mts_ctx *c, vf_xml_node *bsdf, const char **name) {
  char key[64];
  const char *id = bsdf ? vf_xml_attr(bsdf, "id") : NULL;
  if (bsdf == NULL) snprintf(key, sizeof key, "mitsuba-default-diffuse");
  else if (id != NULL && id[0] != '\0' && strlen(id) < sizeof key) snprintf(key, sizeof key, "%s", id);
  else {
    const char *base = strrchr(bsdf->file, '/');
    snprintf(key, sizeof key, "bsdf:%.40s:%d", base ? base + 1 : bsdf->file, bsdf->line);
  }
  cJSON *have = cJSON_GetObjectItemCaseSensitive(c->materials, key);
  if (have != NULL) return *name = have->string, VF_OK;
  cJSON *m = cJSON_CreateObject();
  if (m == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  int twosided = 0;
  int err = bsdf ? build(c, bsdf, m, 0, &twosided) : add_vec3(m, "diffuse", vf_vec3_splat(0.5f));
  if (err == VF_OK && bsdf != NULL) err = check_albedo(bsdf, m);
  if (err < 0 || !cJSON_AddItemToObject(c->materials, key, m)) {
    cJSON_Delete(m);
    return err < 0 ? err : vf_error_set(VF_ENOMEM, "out of memory");
  }
  *name = m->string;
  return VF_OK;
}
