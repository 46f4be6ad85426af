/* A Mitsuba 3 plugin's properties, typed, with its errors and notes (mitsuba_props.h). */
#include "mitsuba_props.h"

#include "../../common/error.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PI 3.14159265358979323846

/* "<bsdf type="diffuse" id="white">" as messages name an element. */
static void describe(const vf_xml_node *e, char *out, size_t n) {
  const char *type = vf_xml_attr(e, "type"), *id = vf_xml_attr(e, "id"), *name = vf_xml_attr(e, "name");
  snprintf(out, n, "<%s%s%s%s%s%s%s%s%s%s>", e->name, type ? " type=\"" : "", type ? type : "", type ? "\"" : "",
           id ? " id=\"" : "", id ? id : "", id ? "\"" : "", name ? " name=\"" : "", name ? name : "", name ? "\"" : "");
}

int mts_fail(const vf_xml_node *e, const char *fmt, ...) {
  char msg[600], what[200];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  describe(e, what, sizeof what);
  return vf_error_set(VF_ESCENE, "%s:%d: %s: %s", e->file, e->line, what, msg);
}

int mts_note(mts_ctx *c, const vf_xml_node *e, const char *fmt, ...) {
  char msg[400], what[200], line[700];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  describe(e, what, sizeof what);
  const char *base = strrchr(e->file, '/');
  snprintf(line, sizeof line, "mitsuba: %s (%s:%d): %s", what, base ? base + 1 : e->file, e->line, msg);
  const cJSON *n;
  cJSON_ArrayForEach(n, c->notes) if (strcmp(n->valuestring, line) == 0) return VF_OK;
  cJSON *s = cJSON_CreateString(line);
  if (s == NULL || !cJSON_AddItemToArray(c->notes, s)) {
    cJSON_Delete(s);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  return VF_OK;
}

int mts_note_unused(mts_ctx *c, const vf_xml_node *e) {
  for (int i = 0; i < e->num_children; i++) {
    const vf_xml_node *p = e->children[i];
    if (p->used) continue;
    const char *name = vf_xml_attr(p, "name");
    int err = name ? mts_note(c, e, "property '%s' (<%s>) is not supported: ignored", name, p->name)
                   : mts_note(c, e, "child <%s> is not supported: ignored", p->name);
    if (err < 0) return err;
  }
  return VF_OK;
}

static vf_xml_node *find_id(vf_xml_node *e, const char *id) {
  const char *own = vf_xml_attr(e, "id");
  if (own != NULL && strcmp(own, id) == 0 && strcmp(e->name, "ref") != 0) return e;
  for (int i = 0; i < e->num_children; i++) {
    vf_xml_node *f = find_id(e->children[i], id);
    if (f != NULL) return f;
  }
  return NULL;
}

vf_xml_node *mts_by_id(mts_ctx *c, const char *id) { return find_id(c->scene, id); }

vf_xml_node *mts_deref(mts_ctx *c, vf_xml_node *e, int *err) {
  *err = VF_OK;
  if (strcmp(e->name, "ref") != 0) return e;
  e->used = 1;
  const char *id = vf_xml_attr(e, "id");
  vf_xml_node *t = id ? mts_by_id(c, id) : NULL;
  if (t == NULL) *err = mts_fail(e, "%s", id ? "names no element of the scene" : "has no id");
  return t;
}

vf_xml_node *mts_child(mts_ctx *c, vf_xml_node *e, const char *name, int *err) {
  *err = VF_OK;
  for (int i = 0; i < e->num_children; i++) {
    vf_xml_node *p = e->children[i];
    const char *n = vf_xml_attr(p, "name");
    if (n == NULL || strcmp(n, name) != 0) continue;
    p->used = 1;
    return mts_deref(c, p, err);
  }
  return NULL;
}

int mts_numbers(const vf_xml_node *e, const char *text, double *out, int max) {
  int n = 0;
  const char *p = text;
  for (;;) {
    while (*p == ' ' || *p == ',' || *p == '\t' || *p == '\n' || *p == '\r') p++;
    if (*p == '\0') return n;
    char *end;
    double v = strtod(p, &end);
    if (end == p || !isfinite(v))
      return mts_fail(e, "'%s' is not a list of finite numbers", text);
    if (n == max) return mts_fail(e, "'%s' has more than %d numbers", text, max);
    out[n++] = v;
    p = end;
  }
}

/* The value attribute of property p as one finite number. */
static int number_value(const vf_xml_node *p, double *out) {
  const char *v = vf_xml_attr(p, "value");
  if (v == NULL) return mts_fail(p, "has no value");
  double x[1];
  int n = mts_numbers(p, v, x, 1);
  if (n < 0) return n;
  if (n != 1) return mts_fail(p, "value '%s' is not one number", v);
  *out = x[0];
  return VF_OK;
}

int mts_float(mts_ctx *c, vf_xml_node *e, const char *name, double def, double *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0) return err;
  if (p == NULL) return 0;
  if (strcmp(p->name, "float") != 0 && strcmp(p->name, "integer") != 0)
    return mts_fail(p, "'%s' must be a <float>", name);
  return (err = number_value(p, out)) < 0 ? err : 1;
}

int mts_int(mts_ctx *c, vf_xml_node *e, const char *name, long def, long *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0) return err;
  if (p == NULL) return 0;
  double v = 0;
  if (strcmp(p->name, "integer") != 0) return mts_fail(p, "'%s' must be an <integer>", name);
  if ((err = number_value(p, &v)) < 0) return err;
  if (v != floor(v) || fabs(v) > 1e9) return mts_fail(p, "value %g is not an integer", v);
  *out = (long)v;
  return 1;
}

int mts_bool(mts_ctx *c, vf_xml_node *e, const char *name, int def, int *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0) return err;
  if (p == NULL) return 0;
  const char *v = vf_xml_attr(p, "value");
  if (strcmp(p->name, "boolean") != 0 || v == NULL) return mts_fail(p, "'%s' must be a <boolean> with a value", name);
  if (strcasecmp(v, "true") == 0) *out = 1;
  else if (strcasecmp(v, "false") == 0) *out = 0;
  else return mts_fail(p, "value '%s' is neither true nor false", v);
  return 1;
}

int mts_string(mts_ctx *c, vf_xml_node *e, const char *name, const char *def, const char **out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0) return err;
  if (p == NULL) return 0;
  const char *v = vf_xml_attr(p, "value");
  if (strcmp(p->name, "string") != 0 || v == NULL) return mts_fail(p, "'%s' must be a <string> with a value", name);
  *out = v;
  return 1;
}

/* x, y, z attributes (each defaulting to def) or value="x, y, z" (one number: all three). */
static int xyz(const vf_xml_node *p, double def, double out[3]) {
  const char *v = vf_xml_attr(p, "value");
  if (v != NULL) {
    int n = mts_numbers(p, v, out, 3);
    if (n < 0) return n;
    if (n == 1) out[1] = out[2] = out[0];
    else if (n != 3) return mts_fail(p, "value '%s' is not 1 or 3 numbers", v);
    return VF_OK;
  }
  static const char *const axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; i++) {
    const char *a = vf_xml_attr(p, axes[i]);
    out[i] = def;
    if (a == NULL) continue;
    int n = mts_numbers(p, a, &out[i], 1);
    if (n < 0) return n;
    if (n != 1) return mts_fail(p, "%s='%s' is not one number", axes[i], a);
  }
  return VF_OK;
}

int mts_point(mts_ctx *c, vf_xml_node *e, const char *name, vf_vec3 def, vf_vec3 *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  if (err < 0) return err;
  if (p == NULL) return 0;
  if (strcmp(p->name, "point") != 0 && strcmp(p->name, "vector") != 0)
    return mts_fail(p, "'%s' must be a <point> or <vector>", name);
  double v[3];
  if ((err = xyz(p, 0, v)) < 0) return err;
  *out = vf_vec3_make((float)v[0], (float)v[1], (float)v[2]);
  return 1;
}

int mts_color(mts_ctx *c, vf_xml_node *e, const char *name, vf_vec3 def, vf_vec3 *out, vf_xml_node **texture) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  *out = def;
  *texture = NULL;
  if (err < 0) return err;
  if (p == NULL) return 0;
  if (strcmp(p->name, "texture") == 0) {
    *texture = p;
    return 2;
  }
  const char *v = vf_xml_attr(p, "value");
  if (v == NULL) return mts_fail(p, "has no value");
  double x[3];
  if (strcmp(p->name, "spectrum") == 0 && strchr(v, ':') != NULL) {
    /* wavelength:value pairs: their plain mean, noted (vcmfarm renders RGB). */
    double pairs[256], sum = 0;
    char copy[2048];
    snprintf(copy, sizeof copy, "%s", v);
    for (char *q = copy; *q; q++)
      if (*q == ':') *q = ' ';
    int n = mts_numbers(p, copy, pairs, 256);
    if (n < 0) return n;
    if (n < 2 || n % 2 != 0) return mts_fail(p, "value '%s' is not wavelength:value pairs", v);
    for (int i = 1; i < n; i += 2) sum += pairs[i];
    *out = vf_vec3_splat((float)(sum / (n / 2)));
    if ((err = mts_note(c, p, "a spectrum of %d samples is rendered as their mean, grey %g", n / 2, sum / (n / 2))) < 0)
      return err;
    return 1;
  }
  if (strcmp(p->name, "rgb") != 0 && strcmp(p->name, "spectrum") != 0 && strcmp(p->name, "float") != 0)
    return mts_fail(p, "'%s' must be an <rgb>, a <spectrum>, a <float> or a <texture>", name);
  int n = mts_numbers(p, v, x, 3);
  if (n < 0) return n;
  if (n == 1) x[1] = x[2] = x[0];
  else if (n != 3 || strcmp(p->name, "float") == 0) return mts_fail(p, "value '%s' is not 1 or 3 numbers", v);
  *out = vf_vec3_make((float)x[0], (float)x[1], (float)x[2]);
  return 1;
}

static void set_affine(vf_affine *a, const double m[3][4]) { memcpy(a->m, m, sizeof a->m); }

/* Mitsuba's look_at: columns left, up, forward and the origin, where
 * left = normalize(cross(up, forward)) and up is made orthogonal to both. */
static int lookat(const vf_xml_node *op, vf_affine *a) {
  double o[3], t[3], u[3];
  const char *so = vf_xml_attr(op, "origin"), *st = vf_xml_attr(op, "target"), *su = vf_xml_attr(op, "up");
  if (so == NULL || st == NULL) return mts_fail(op, "needs an origin and a target");
  int n;
  if ((n = mts_numbers(op, so, o, 3)) < 0) return n;
  if (n != 3) return mts_fail(op, "origin '%s' is not 3 numbers", so);
  if ((n = mts_numbers(op, st, t, 3)) < 0) return n;
  if (n != 3) return mts_fail(op, "target '%s' is not 3 numbers", st);
  if (su == NULL) u[0] = 0, u[1] = 1, u[2] = 0;
  else if ((n = mts_numbers(op, su, u, 3)) < 0) return n;
  else if (n != 3) return mts_fail(op, "up '%s' is not 3 numbers", su);
  double d[3] = {t[0] - o[0], t[1] - o[1], t[2] - o[2]};
  double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(dl > 0)) return mts_fail(op, "origin and target are the same point");
  for (int i = 0; i < 3; i++) d[i] /= dl;
  double l[3] = {u[1] * d[2] - u[2] * d[1], u[2] * d[0] - u[0] * d[2], u[0] * d[1] - u[1] * d[0]};
  double ll = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  if (!(ll > 1e-9)) return mts_fail(op, "up is parallel to the viewing direction (or zero)");
  for (int i = 0; i < 3; i++) l[i] /= ll;
  double nu[3] = {d[1] * l[2] - d[2] * l[1], d[2] * l[0] - d[0] * l[2], d[0] * l[1] - d[1] * l[0]};
  double m[3][4];
  for (int i = 0; i < 3; i++) {
    m[i][0] = l[i];
    m[i][1] = nu[i];
    m[i][2] = d[i];
    m[i][3] = o[i];
  }
  set_affine(a, m);
  return VF_OK;
}

static int operation(const vf_xml_node *op, vf_affine *a) {
  double m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  double v[16];
  int err;
  if (strcmp(op->name, "translate") == 0) {
    if ((err = xyz(op, 0, v)) < 0) return err;
    for (int i = 0; i < 3; i++) m[i][3] = v[i];
  } else if (strcmp(op->name, "scale") == 0) {
    if ((err = xyz(op, 1, v)) < 0) return err;
    for (int i = 0; i < 3; i++) m[i][i] = v[i];
  } else if (strcmp(op->name, "rotate") == 0) {
    const char *angle = vf_xml_attr(op, "angle");
    double deg;
    if (angle == NULL) return mts_fail(op, "needs an angle (degrees)");
    if ((err = xyz(op, 0, v)) < 0 || (err = mts_numbers(op, angle, &deg, 1)) < 0) return err;
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0)) return mts_fail(op, "the rotation axis is zero");
    double x = v[0] / len, y = v[1] / len, z = v[2] / len, s = sin(deg * PI / 180), co = cos(deg * PI / 180),
           t = 1 - co;
    double r[3][3] = {{t * x * x + co, t * x * y - s * z, t * x * z + s * y},
                      {t * x * y + s * z, t * y * y + co, t * y * z - s * x},
                      {t * x * z - s * y, t * y * z + s * x, t * z * z + co}};
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) m[i][j] = r[i][j];
  } else if (strcmp(op->name, "matrix") == 0) {
    const char *value = vf_xml_attr(op, "value");
    if (value == NULL) return mts_fail(op, "has no value");
    int n = mts_numbers(op, value, v, 16);
    if (n < 0) return n;
    if (n == 9) {
      for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) m[i][j] = v[3 * i + j];
    } else if (n == 16) {
      if (v[12] != 0 || v[13] != 0 || v[14] != 0 || v[15] != 1)
        return mts_fail(op, "a projective matrix (last row %g %g %g %g, not 0 0 0 1) is not supported", v[12], v[13],
                        v[14], v[15]);
      for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) m[i][j] = v[4 * i + j];
    } else {
      return mts_fail(op, "has %d numbers, not 16 (or 9)", n);
    }
  } else if (strcasecmp(op->name, "lookat") == 0) { /* Mitsuba 0.x wrote <lookAt> */
    return lookat(op, a);
  } else {
    return mts_fail(op, "is not a transform operation (translate, rotate, scale, matrix, lookat)");
  }
  set_affine(a, m);
  return VF_OK;
}

int mts_transform(mts_ctx *c, vf_xml_node *e, const char *name, vf_affine *out) {
  int err;
  vf_xml_node *p = mts_child(c, e, name, &err);
  vf_affine_identity(out);
  if (err < 0) return err;
  if (p == NULL) return 0;
  if (strcmp(p->name, "transform") != 0) return mts_fail(p, "'%s' must be a <transform>", name);
  vf_affine total, op;
  vf_affine_identity(&total);
  for (int i = 0; i < p->num_children; i++) {
    p->children[i]->used = 1;
    if ((err = operation(p->children[i], &op)) < 0) return err;
    vf_affine_mul(&op, &total, &total); /* each operation after those before it */
  }
  *out = total;
  return 1;
}

cJSON *mts_vec3_json(vf_vec3 v) {
  const double d[3] = {v.x, v.y, v.z};
  return cJSON_CreateDoubleArray(d, 3);
}

vf_vec3 mts_apply_point(const vf_affine *a, double x, double y, double z) {
  double in[3] = {x, y, z}, out[3];
  vf_affine_point(a, in, out);
  return vf_vec3_make((float)out[0], (float)out[1], (float)out[2]);
}

vf_vec3 mts_apply_vector(const vf_affine *a, double x, double y, double z) {
  double in[3] = {x, y, z}, out[3];
  vf_affine_vector(a, in, out);
  return vf_vec3_make((float)out[0], (float)out[1], (float)out[2]);
}

double mts_column_length(const vf_affine *a, int j) {
  return sqrt(a->m[0][j] * a->m[0][j] + a->m[1][j] * a->m[1][j] + a->m[2][j] * a->m[2][j]);
}
