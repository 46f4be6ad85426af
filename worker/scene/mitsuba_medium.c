/* Mitsuba 3 media (mitsuba_medium.h). Mitsuba's homogeneous medium is written in
 * extinction and albedo, scaled: sigma_t' = scale sigma_t, sigma_s = albedo sigma_t',
 * sigma_a = sigma_t' - sigma_s; its phase function is isotropic by default, or
 * Henyey-Greenstein ("hg", g by default 0.8). */
#include "mitsuba_medium.h"

#include "../../common/error.h"

#include <stdio.h>
#include <string.h>

static int oom(void) { return vf_error_set(VF_ENOMEM, "out of memory"); }

/* The phase function's g: 0 for none or "isotropic", "hg"'s g; another is noted and read
 * as isotropic. */
static int phase_g(mts_ctx *c, vf_xml_node *m, double *g) {
  int err;
  vf_xml_node *phase = NULL;
  *g = 0.0;
  for (int i = 0; i < m->num_children && phase == NULL; i++)
    if (strcmp(m->children[i]->name, "phase") == 0) phase = m->children[i];
  if (phase == NULL) return VF_OK;
  phase->used = 1;
  const char *type = vf_xml_attr(phase, "type");
  if (type != NULL && strcmp(type, "hg") == 0) {
    if ((err = mts_float(c, phase, "g", 0.8, g)) < 0) return err;
    if (!(*g > -1.0 && *g < 1.0)) return mts_fail(phase, "g must be in (-1, 1), found %g", *g);
    return mts_note_unused(c, phase);
  }
  if (type != NULL && strcmp(type, "isotropic") == 0) return mts_note_unused(c, phase);
  for (int i = 0; i < phase->num_children; i++) phase->children[i]->used = 1;
  return mts_note(c, phase, "phase function '%s' is not supported: isotropic", type ? type : "?");
}

static cJSON *rgb_json(vf_vec3 v) { return mts_vec3_json(v); }

int mts_medium(mts_ctx *c, vf_xml_node *e, const char **name) {
  int err;
  *name = NULL;
  vf_xml_node *m = mts_deref(c, e, &err);
  if (m == NULL) return err;
  e->used = 1;
  if (strcmp(m->name, "medium") != 0) return mts_fail(e, "names a <%s>, not a <medium>", m->name);
  /* Its name in the JSON: its id, or its place in the file for an unnamed one. */
  char key[64];
  const char *id = vf_xml_attr(m, "id");
  if (id != NULL && strlen(id) < sizeof key) snprintf(key, sizeof key, "%s", id);
  else snprintf(key, sizeof key, "medium at line %d", m->line);
  cJSON *media = cJSON_GetObjectItemCaseSensitive(c->root, "media");
  if (media == NULL && (media = cJSON_AddObjectToObject(c->root, "media")) == NULL) return oom();
  const cJSON *known = cJSON_GetObjectItemCaseSensitive(media, key);
  if (known != NULL) {
    *name = known->string;
    return VF_OK;
  }
  m->used = 1; /* a refusal below is noted again for each use, and kept once (mts_note) */
  const char *type = vf_xml_attr(m, "type");
  if (type == NULL || strcmp(type, "homogeneous") != 0) {
    for (int i = 0; i < m->num_children; i++) m->children[i]->used = 1;
    return mts_note(c, m, "medium '%s' is not supported (homogeneous only): left out, vacuum instead", type ? type : "?");
  }
  vf_vec3 albedo, sigma_t;
  vf_xml_node *texture = NULL;
  double scale, g;
  int a = mts_color(c, m, "albedo", vf_vec3_splat(0.75f), &albedo, &texture);
  if (a < 0) return a;
  int t = mts_color(c, m, "sigma_t", vf_vec3_splat(1.0f), &sigma_t, &texture);
  if (t < 0) return t;
  if (a == 2 || t == 2) {
    for (int i = 0; i < m->num_children; i++) m->children[i]->used = 1;
    return mts_note(c, m, "a medium with a volume texture (a grid) is not supported: left out, vacuum instead");
  }
  if ((err = mts_float(c, m, "scale", 1.0, &scale)) < 0 || (err = phase_g(c, m, &g)) < 0) return err;
  if (!(scale >= 0.0)) return mts_fail(m, "scale must be >= 0, found %g", scale);
  for (int k = 0; k < 3; k++) {
    float ak = vf_vec3_get(albedo, k), tk = vf_vec3_get(sigma_t, k);
    if (!(ak >= 0.0f && ak <= 1.0f)) return mts_fail(m, "albedo must be in [0, 1], found %g", ak);
    if (!(tk >= 0.0f)) return mts_fail(m, "sigma_t must be >= 0, found %g", tk);
  }
  vf_vec3 extinction = vf_scale(sigma_t, (float)scale), scattering = vf_mul(albedo, extinction);
  vf_vec3 absorption = vf_sub(extinction, scattering);
  absorption = vf_vec3_make(absorption.x > 0 ? absorption.x : 0, absorption.y > 0 ? absorption.y : 0,
                            absorption.z > 0 ? absorption.z : 0); /* rounding: never below 0 */
  cJSON *j = cJSON_CreateObject();
  if (j == NULL || !cJSON_AddItemToObject(media, key, j)) return cJSON_Delete(j), oom();
  if (!cJSON_AddItemToObject(j, "sigma_a", rgb_json(absorption)) ||
      !cJSON_AddItemToObject(j, "sigma_s", rgb_json(scattering)) || !cJSON_AddNumberToObject(j, "g", g))
    return oom();
  *name = j->string;
  int sample_emitted;
  if ((err = mts_bool(c, m, "sample_emitted", 1, &sample_emitted)) < 0) return err;
  return mts_note_unused(c, m);
}
