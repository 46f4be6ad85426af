/* Mitsuba 3 scene files as an element tree (xml.c): parsed with expat, `<include>` files
 * spliced in where they stand, `<default>` values recorded and every `$name` in an
 * attribute value replaced by its value, in document order as Mitsuba does. What the
 * elements mean is mitsuba.c's business. Private to worker/scene/. */
#ifndef VF_SCENE_XML_H
#define VF_SCENE_XML_H

/* One element. Everything is owned by the tree (vf_xml_free of the root). */
typedef struct vf_xml_node {
  char *name;               /* the tag: "shape", "float", "transform", ... */
  char **attrs;             /* name, value, name, value, ..., values already substituted */
  int num_attrs;
  struct vf_xml_node **children;
  int num_children, cap_children;
  char *file;               /* the file it was read from, for messages */
  int line;
  int used;                 /* set by the reader of the element (mitsuba.c): unused ones are noted */
} vf_xml_node;

/* Parses Mitsuba scene `path` into *out, the <scene> element, on success only. Included
 * files resolve against the directory of the file including them, at most 16 deep.
 * Errors (VF_ESCENE: malformed XML, an unknown $name, a root other than <scene>, an
 * include loop; VF_ENOENT: a file that cannot be read; VF_ENOMEM) name the file and line. */
int vf_xml_read(const char *path, vf_xml_node **out);
void vf_xml_free(vf_xml_node *node);

/* The value of attribute `name`, or NULL. */
const char *vf_xml_attr(const vf_xml_node *node, const char *name);

#endif
