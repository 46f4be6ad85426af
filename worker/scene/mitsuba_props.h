/* Reading a Mitsuba 3 plugin's properties (mitsuba_props.c): typed values of the child
 * elements of a <bsdf>, <shape>, <emitter>, <sensor>, ... with Mitsuba's defaults, `<ref>`
 * resolved by id, transforms composed, and the conversion's errors and notes. Errors
 * (VF_ESCENE) name the file, the line, the element and the reason; notes name the element
 * and what was done instead. Private to worker/scene/ (mitsuba.c, mitsuba_bsdf.c). */
#ifndef VF_SCENE_MITSUBA_PROPS_H
#define VF_SCENE_MITSUBA_PROPS_H

#include "../../common/vec3.h"
#include "mesh.h"
#include "xml.h"

#include <cjson/cJSON.h>

/* The conversion of one scene file into the JSON scene of docs/SCENES.md. */
typedef struct {
  vf_xml_node *scene;   /* the <scene> element, borrowed */
  cJSON *root;          /* the JSON scene being built: owned by the caller */
  cJSON *materials, *shapes, *lights, *notes;
  char dir[4096];       /* the scene file's directory: file names are written relative to it */
} mts_ctx;

/* VF_ESCENE "FILE:LINE: <name type=... id=...>: reason". */
int mts_fail(const vf_xml_node *e, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* A note "<name type=...> (FILE:LINE): text" into the JSON scene's "notes", each once.
 * VF_ENOMEM only. */
int mts_note(mts_ctx *c, const vf_xml_node *e, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* Notes every child of e that no reader marked used ("property 'near_clip' ignored"). */
int mts_note_unused(mts_ctx *c, const vf_xml_node *e);

/* The element named `name` among e's children (marked used), following a <ref id=...> to
 * the element of that id anywhere in the scene; NULL when absent. A <ref> naming no
 * element is an error (*err < 0); *err is VF_OK otherwise. */
vf_xml_node *mts_child(mts_ctx *c, vf_xml_node *e, const char *name, int *err);
/* The element of id `id` anywhere in the scene, or NULL. */
vf_xml_node *mts_by_id(mts_ctx *c, const char *id);
/* e itself, or the element a <ref> e names (an error when it names none: NULL, *err). */
vf_xml_node *mts_deref(mts_ctx *c, vf_xml_node *e, int *err);

/* Typed properties: 1 read, 0 absent (*out = def), < 0 error. Numbers must be finite. */
int mts_float(mts_ctx *c, vf_xml_node *e, const char *name, double def, double *out);
int mts_int(mts_ctx *c, vf_xml_node *e, const char *name, long def, long *out);
int mts_bool(mts_ctx *c, vf_xml_node *e, const char *name, int def, int *out);
int mts_string(mts_ctx *c, vf_xml_node *e, const char *name, const char *def, const char **out);
/* <point>/<vector> with x, y, z or value="x, y, z". */
int mts_point(mts_ctx *c, vf_xml_node *e, const char *name, vf_vec3 def, vf_vec3 *out);
/* A colour: <rgb>, <spectrum> (uniform, or wavelength:value pairs averaged with a note),
 * <float>; or a texture (<texture> or a <ref> to one): then 2 and *texture set, *out = def. */
int mts_color(mts_ctx *c, vf_xml_node *e, const char *name, vf_vec3 def, vf_vec3 *out, vf_xml_node **texture);
/* <transform name=...>: its operations (translate, rotate, scale, matrix, lookat) each
 * applied after those before it; identity when absent. */
int mts_transform(mts_ctx *c, vf_xml_node *e, const char *name, vf_affine *out);

/* Numbers separated by commas or white space into out (at most max): their count, or < 0
 * (an error naming e) when one is not a finite number. */
int mts_numbers(const vf_xml_node *e, const char *text, double *out, int max);

cJSON *mts_vec3_json(vf_vec3 v);

/* a applied to the point or the vector (x, y, z); the length of a's column j. */
vf_vec3 mts_apply_point(const vf_affine *a, double x, double y, double z);
vf_vec3 mts_apply_vector(const vf_affine *a, double x, double y, double z);
double mts_column_length(const vf_affine *a, int j);

#endif
