/* Files of a scene by name: recorded from the file system on `submit`, mapped to a blob
 * store on workers (files.h). Assimp reaches them through a C aiFileIO. */
#include "files.h"

#include "../../common/error.h"
#include "assimp_api.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

typedef struct {
  char *name, *path;
} recorded_file;

struct vf_scene_files {
  int recording;
  char base_dir[4096];           /* recording */
  recorded_file *opened;         /* recording: owned, each name once */
  size_t num_opened;
  const vf_blob_table *table;    /* mapping: borrowed */
  const char *store_dir;         /* mapping: borrowed */
  /* Assimp's view of this object. Assimp keeps a pointer to it inside an imported scene
   * until aiReleaseImport, so it lives here rather than on an import's stack. */
  struct aiFileIO io;
};

int vf_scene_files_recording(const char *base_dir, vf_scene_files **out) {
  vf_scene_files *f = calloc(1, sizeof *f);
  if (f == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  if (snprintf(f->base_dir, sizeof f->base_dir, "%s", base_dir) >= (int)sizeof f->base_dir) {
    free(f);
    return vf_error_set(VF_EINVAL, "%s: directory name too long", base_dir);
  }
  f->recording = 1;
  *out = f;
  return VF_OK;
}

int vf_scene_files_mapping(const vf_blob_table *table, const char *store_dir, vf_scene_files **out) {
  vf_scene_files *f = calloc(1, sizeof *f);
  if (f == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  f->table = table;
  f->store_dir = store_dir;
  *out = f;
  return VF_OK;
}

void vf_scene_files_destroy(vf_scene_files *f) {
  if (f == NULL) return;
  for (size_t i = 0; i < f->num_opened; i++) {
    free(f->opened[i].name);
    free(f->opened[i].path);
  }
  free(f->opened);
  free(f);
}

size_t vf_scene_files_count(const vf_scene_files *f) { return f->num_opened; }
const char *vf_scene_files_name(const vf_scene_files *f, size_t i) { return f->opened[i].name; }
const char *vf_scene_files_path(const vf_scene_files *f, size_t i) { return f->opened[i].path; }

static int record(vf_scene_files *f, const char *name, const char *path) {
  for (size_t i = 0; i < f->num_opened; i++)
    if (strcmp(f->opened[i].name, name) == 0) return VF_OK;
  recorded_file *grown = realloc(f->opened, (f->num_opened + 1) * sizeof *grown);
  if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  f->opened = grown;
  recorded_file *r = &f->opened[f->num_opened];
  r->name = strdup(name);
  r->path = strdup(path);
  if (r->name == NULL || r->path == NULL) {
    free(r->name);
    free(r->path);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  f->num_opened++;
  return VF_OK;
}

int vf_scene_files_resolve(vf_scene_files *f, const char *name, char *out, size_t n) {
  if (!f->recording) {
    const vf_blob_ref *ref = vf_blob_table_find(f->table, name);
    if (ref == NULL) return vf_error_set(VF_ENOENT, "cannot open '%s': not among the job's files", name);
    return vf_blob_path(f->store_dir, ref->hash, out, n);
  }
  int w = name[0] == '/' ? snprintf(out, n, "%s", name) : snprintf(out, n, "%s/%s", f->base_dir, name);
  if (w < 0 || (size_t)w >= n) return vf_error_set(VF_EINVAL, "cannot open '%s': path too long", name);
  struct stat st;
  if (stat(out, &st) != 0) return vf_error_set(VF_ENOENT, "cannot open '%s': %s", name, strerror(errno));
  if (!S_ISREG(st.st_mode)) return vf_error_set(VF_ENOENT, "cannot open '%s': not a regular file", name);
  /* Refused before anything parses it: it could not be sent. */
  if ((uint64_t)st.st_size > VF_BLOB_MAX_BYTES)
    return vf_error_set(VF_ESCENE, "'%s' is %.1f MiB; a file sent to a farm can be at most %llu MiB "
                        "(`vcmfarm render` renders it on one machine)", name,
                        (double)st.st_size / 1048576.0, (unsigned long long)(VF_BLOB_MAX_BYTES >> 20));
  return record(f, name, out);
}

/* ---- Assimp's view: a read-only aiFileIO over resolve() ---------------------------------- */

static size_t file_read(struct aiFile *file, char *buffer, size_t size, size_t count) {
  return fread(buffer, size, count, (FILE *)file->UserData);
}

static size_t file_write(struct aiFile *file, const char *buffer, size_t size, size_t count) { return 0; }

static size_t file_tell(struct aiFile *file) {
  long at = ftell((FILE *)file->UserData);
  return at < 0 ? 0 : (size_t)at;
}

static size_t file_size(struct aiFile *file) {
  struct stat st;
  return fstat(fileno((FILE *)file->UserData), &st) == 0 ? (size_t)st.st_size : 0;
}

static enum aiReturn file_seek(struct aiFile *file, size_t offset, enum aiOrigin origin) {
  /* Assimp passes backward relative offsets as wrapped size_t: the cast restores them. */
  int whence = origin == aiOrigin_SET ? SEEK_SET : origin == aiOrigin_CUR ? SEEK_CUR : SEEK_END;
  return fseek((FILE *)file->UserData, (long)offset, whence) == 0 ? aiReturn_SUCCESS : aiReturn_FAILURE;
}

static void file_flush(struct aiFile *file) {}

static struct aiFile *io_open(struct aiFileIO *io, const char *name, const char *mode) {
  vf_scene_files *f = (vf_scene_files *)io->UserData;
  char path[4200];
  if (strchr(mode, 'w') || strchr(mode, 'a') || strchr(mode, '+')) return NULL; /* loading only reads */
  if (vf_scene_files_resolve(f, name, path, sizeof path) != VF_OK) return NULL;
  FILE *fp = fopen(path, "rb");
  if (fp == NULL) return NULL;
  struct aiFile *file = calloc(1, sizeof *file);
  if (file == NULL) {
    fclose(fp);
    return NULL;
  }
  file->ReadProc = file_read;
  file->WriteProc = file_write;
  file->TellProc = file_tell;
  file->FileSizeProc = file_size;
  file->SeekProc = file_seek;
  file->FlushProc = file_flush;
  file->UserData = (aiUserData)fp;
  return file;
}

static void io_close(struct aiFileIO *io, struct aiFile *file) {
  if (file == NULL) return;
  fclose((FILE *)file->UserData);
  free(file);
}

const struct aiScene *vf_scene_files_import(vf_scene_files *f, const char *name, unsigned flags) {
  f->io = (struct aiFileIO){io_open, io_close, (aiUserData)f};
  return vf_assimp()->aiImportFileEx(name, flags, &f->io);
}
