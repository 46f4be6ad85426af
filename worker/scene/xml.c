/* Mitsuba scene files as an element tree, through expat (xml.h). */
#include "xml.h"

#include "../../common/error.h"

#include <ctype.h>
#include <errno.h>
#include <expat.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Scene files hold meshes by reference: anything larger is not a scene description. */
#define MAX_XML_BYTES ((size_t)64 << 20)
#define MAX_INCLUDE_DEPTH 16

typedef struct {
  char **names, **values; /* <default> parameters, in the order declared */
  int count, cap;
} defaults;

typedef struct {
  XML_Parser parser;
  const char *file;
  defaults *defs;
  int depth;              /* of includes */
  vf_xml_node *stack[256];
  int top;                /* elements open: stack[0 .. top) */
  vf_xml_node *root;
  int err;                /* the first error, its detail set */
} reader;

static int read_tree(const char *path, defaults *defs, int depth, vf_xml_node **out);

void vf_xml_free(vf_xml_node *node) {
  if (node == NULL) return;
  for (int i = 0; i < node->num_children; i++) vf_xml_free(node->children[i]);
  for (int i = 0; i < 2 * node->num_attrs; i++) free(node->attrs[i]);
  free(node->attrs);
  free(node->children);
  free(node->name);
  free(node->file);
  free(node);
}

const char *vf_xml_attr(const vf_xml_node *node, const char *name) {
  for (int i = 0; i < node->num_attrs; i++)
    if (strcmp(node->attrs[2 * i], name) == 0) return node->attrs[2 * i + 1];
  return NULL;
}

static int add_child(vf_xml_node *parent, vf_xml_node *child) {
  if (parent->num_children == parent->cap_children) {
    int cap = parent->cap_children ? 2 * parent->cap_children : 8;
    vf_xml_node **grown = realloc(parent->children, (size_t)cap * sizeof *grown);
    if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
    parent->children = grown;
    parent->cap_children = cap;
  }
  parent->children[parent->num_children++] = child;
  return VF_OK;
}

static void stop(reader *r, int err) {
  if (r->err == VF_OK) r->err = err;
  XML_StopParser(r->parser, XML_FALSE);
}

/* `value` with every $name replaced by its <default>: a new string, or NULL with r->err. */
static char *substitute(reader *r, const char *element, const char *attr, const char *value, int line, int *err) {
  size_t cap = strlen(value) + 1, n = 0;
  char *out = malloc(cap);
  *err = VF_ENOMEM;
  if (out == NULL) return vf_error_set(VF_ENOMEM, "out of memory"), NULL;
  for (const char *p = value; *p != '\0';) {
    const char *insert = p;
    size_t len = 1;
    if (*p == '$') {
      const char *q = p + 1;
      while (isalnum((unsigned char)*q) || *q == '_') q++;
      int found = -1;
      for (int i = 0; i < r->defs->count; i++)
        if (strlen(r->defs->names[i]) == (size_t)(q - p - 1) && strncmp(r->defs->names[i], p + 1, (size_t)(q - p - 1)) == 0)
          found = i;
      if (found < 0) {
        *err = vf_error_set(VF_ESCENE, "%s:%d: <%s %s=\"%s\">: '%.*s' names no <default> parameter declared before it",
                            r->file, line, element, attr, value, (int)(q - p), p);
        free(out);
        return NULL;
      }
      insert = r->defs->values[found];
      len = strlen(insert);
      p = q;
    } else {
      p++;
    }
    if (n + len + 1 > cap) {
      cap = 2 * (n + len + 1);
      char *grown = cap > MAX_XML_BYTES ? NULL : realloc(out, cap);
      if (grown == NULL) {
        free(out);
        *err = vf_error_set(VF_ESCENE, "%s:%d: a substituted value grows beyond %zu MiB", r->file, line, MAX_XML_BYTES >> 20);
        return NULL;
      }
      out = grown;
    }
    memcpy(out + n, insert, len);
    n += len;
  }
  out[n] = '\0';
  return out;
}

/* <default name="..." value="...">: the first declaration of a name wins (Mitsuba lets the
 * command line's -D override a default; vcmfarm has no such option). */
static int add_default(reader *r, const vf_xml_node *e) {
  const char *name = vf_xml_attr(e, "name"), *value = vf_xml_attr(e, "value");
  if (name == NULL || value == NULL || name[0] == '\0')
    return vf_error_set(VF_ESCENE, "%s:%d: <default> needs a name and a value", e->file, e->line);
  for (int i = 0; i < r->defs->count; i++)
    if (strcmp(r->defs->names[i], name) == 0) return VF_OK;
  if (r->defs->count == r->defs->cap) {
    int cap = r->defs->cap ? 2 * r->defs->cap : 8;
    char **n = realloc(r->defs->names, (size_t)cap * sizeof *n);
    if (n == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
    r->defs->names = n;
    char **v = realloc(r->defs->values, (size_t)cap * sizeof *v);
    if (v == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
    r->defs->values = v;
    r->defs->cap = cap;
  }
  char *nc = strdup(name), *vc = strdup(value);
  if (nc == NULL || vc == NULL) {
    free(nc);
    free(vc);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  r->defs->names[r->defs->count] = nc;
  r->defs->values[r->defs->count++] = vc;
  return VF_OK;
}

/* <include filename="...">: the included file's <scene> children join the includer's
 * parent element in place. */
static int include_file(reader *r, const vf_xml_node *e, vf_xml_node *parent) {
  const char *name = vf_xml_attr(e, "filename");
  if (name == NULL) return vf_error_set(VF_ESCENE, "%s:%d: <include> needs a filename", e->file, e->line);
  if (r->depth + 1 >= MAX_INCLUDE_DEPTH)
    return vf_error_set(VF_ESCENE, "%s:%d: includes nest more than %d deep (does a file include itself?)", e->file,
                        e->line, MAX_INCLUDE_DEPTH);
  char path[4096];
  const char *slash = strrchr(r->file, '/');
  int w = name[0] == '/' || slash == NULL ? snprintf(path, sizeof path, "%s", name)
                                          : snprintf(path, sizeof path, "%.*s/%s", (int)(slash - r->file), r->file, name);
  if (w < 0 || (size_t)w >= sizeof path) return vf_error_set(VF_ESCENE, "%s:%d: include path too long", e->file, e->line);
  /* A file that cannot be opened is the include's fault; errors inside it name their own
   * file and line. */
  FILE *f = fopen(path, "rb");
  if (f == NULL)
    return vf_error_set(VF_ENOENT, "%s:%d: <include filename=\"%s\">: cannot open %s: %s", e->file, e->line, name, path,
                        strerror(errno));
  fclose(f);
  vf_xml_node *sub;
  int err = read_tree(path, r->defs, r->depth + 1, &sub);
  if (err != VF_OK) return err;
  for (int i = 0; i < sub->num_children && err == VF_OK; i++) {
    if ((err = add_child(parent, sub->children[i])) == VF_OK) sub->children[i] = NULL;
  }
  vf_xml_free(sub);
  return err;
}

static void XMLCALL on_start(void *user, const XML_Char *name, const XML_Char **attrs) {
  reader *r = user;
  if (r->err != VF_OK) return;
  int line = (int)XML_GetCurrentLineNumber(r->parser);
  if (r->top == (int)(sizeof r->stack / sizeof r->stack[0])) {
    stop(r, vf_error_set(VF_ESCENE, "%s:%d: elements nest more than %d deep", r->file, line, r->top));
    return;
  }
  vf_xml_node *e = calloc(1, sizeof *e);
  int n = 0;
  while (attrs[2 * n] != NULL) n++;
  if (e == NULL || (e->name = strdup(name)) == NULL || (e->file = strdup(r->file)) == NULL ||
      (n > 0 && (e->attrs = calloc(2 * (size_t)n, sizeof *e->attrs)) == NULL)) {
    vf_xml_free(e);
    stop(r, vf_error_set(VF_ENOMEM, "out of memory"));
    return;
  }
  e->line = line;
  for (int i = 0; i < n; i++) {
    e->num_attrs = i + 1;
    if ((e->attrs[2 * i] = strdup(attrs[2 * i])) == NULL) {
      vf_xml_free(e);
      stop(r, vf_error_set(VF_ENOMEM, "out of memory"));
      return;
    }
    /* A <default>'s own value is taken as written. */
    int serr = VF_ENOMEM;
    e->attrs[2 * i + 1] = strcmp(name, "default") == 0 ? strdup(attrs[2 * i + 1]) : substitute(r, name, attrs[2 * i], attrs[2 * i + 1], line, &serr);
    if (e->attrs[2 * i + 1] == NULL) {
      vf_xml_free(e);
      stop(r, serr == VF_ENOMEM ? vf_error_set(VF_ENOMEM, "out of memory") : serr);
      return;
    }
  }
  vf_xml_node *parent = r->top > 0 ? r->stack[r->top - 1] : NULL;
  int err = VF_OK;
  if (parent == NULL) {
    if (strcmp(name, "scene") != 0) err = vf_error_set(VF_ESCENE, "%s:%d: the root element is <%s>, not <scene>", r->file, line, name);
    else r->root = e;
  } else if (strcmp(name, "default") == 0) {
    err = add_default(r, e);
  } else if (strcmp(name, "include") == 0) {
    err = include_file(r, e, parent);
  } else {
    err = add_child(parent, e);
    e = err == VF_OK ? NULL : e; /* the parent owns it now */
  }
  if (err != VF_OK) {
    if (e != r->root) vf_xml_free(e);
    stop(r, err);
    return;
  }
  /* <default> and <include> stay on the stack (they have no children in a valid file)
   * and are freed at their end tag. */
  r->stack[r->top++] = parent == NULL ? r->root : e != NULL ? e : parent->children[parent->num_children - 1];
}

static void XMLCALL on_end(void *user, const XML_Char *name) {
  reader *r = user;
  if (r->err != VF_OK || r->top == 0) return;
  vf_xml_node *e = r->stack[--r->top];
  if (r->top > 0 && (strcmp(name, "default") == 0 || strcmp(name, "include") == 0)) {
    if (e->num_children > 0) stop(r, vf_error_set(VF_ESCENE, "%s:%d: <%s> has child elements", e->file, e->line, name));
    vf_xml_free(e);
  }
}

static int read_file(const char *path, char **text, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (f == NULL) return vf_error_set(VF_ENOENT, "%s: cannot open: %s", path, strerror(errno));
  char *buf = malloc(MAX_XML_BYTES + 1);
  size_t n = buf ? fread(buf, 1, MAX_XML_BYTES + 1, f) : 0;
  int bad = ferror(f);
  fclose(f);
  if (buf == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  if (bad || n > MAX_XML_BYTES) {
    free(buf);
    return bad ? vf_error_set(VF_ENOENT, "%s: read error", path)
               : vf_error_set(VF_ESCENE, "%s: larger than %zu MiB", path, MAX_XML_BYTES >> 20);
  }
  *text = buf;
  *len = n;
  return VF_OK;
}

static int read_tree(const char *path, defaults *defs, int depth, vf_xml_node **out) {
  char *text = NULL;
  size_t len = 0;
  int err = read_file(path, &text, &len);
  if (err != VF_OK) return err;
  reader r = {.file = path, .defs = defs, .depth = depth, .err = VF_OK};
  r.parser = XML_ParserCreate(NULL);
  if (r.parser == NULL) {
    free(text);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  XML_SetUserData(r.parser, &r);
  XML_SetElementHandler(r.parser, on_start, on_end);
  if (XML_Parse(r.parser, text, (int)len, XML_TRUE) == XML_STATUS_ERROR && r.err == VF_OK)
    r.err = vf_error_set(VF_ESCENE, "%s:%lu: malformed XML: %s", path, (unsigned long)XML_GetCurrentLineNumber(r.parser),
                         XML_ErrorString(XML_GetErrorCode(r.parser)));
  if (r.err == VF_OK && r.root == NULL) r.err = vf_error_set(VF_ESCENE, "%s: no <scene> element", path);
  XML_ParserFree(r.parser);
  free(text);
  /* A file that ends inside a <default> or <include> leaves it unowned on the stack. */
  for (int i = 1; i < r.top; i++)
    if (strcmp(r.stack[i]->name, "default") == 0 || strcmp(r.stack[i]->name, "include") == 0) vf_xml_free(r.stack[i]);
  if (r.err != VF_OK) {
    vf_xml_free(r.root);
    return r.err;
  }
  *out = r.root;
  return VF_OK;
}

int vf_xml_read(const char *path, vf_xml_node **out) {
  defaults defs = {0};
  int err = read_tree(path, &defs, 0, out);
  for (int i = 0; i < defs.count; i++) {
    free(defs.names[i]);
    free(defs.values[i]);
  }
  free(defs.names);
  free(defs.values);
  return err;
}
