#include "submit.h"
#include "options.h"

#include "../common/error.h"
#include "../common/file.h"
#include "../common/image.h"
#include "../common/parse.h"
#include "../coordinator/job.h" /* VF_JOB_MAX_NAME */
#include "../common/wire.h"
#include "../worker/scene/job_scene.h"
#include "../worker/scene/load.h"
#include "../worker/render/render.h"
#include "../worker/render/vcm.h"
#include "render_job.h"
#include "../worker/scene/builtin.h"

#include <sodium.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Sends one blob of the stage in chunks of VF_BLOB_CHUNK_BYTES, one per message. */
static int send_blob(vf_farm_client *client, int timeout_ms, const char *stage, const vf_blob_ref *ref) {
  uint64_t transfer, offset = 0, total = ref->size;
  randombytes_buf(&transfer, sizeof transfer);
  int err = VF_OK;
  do {
    uint8_t *bytes;
    size_t len;
    uint64_t size;
    if ((err = vf_blob_store_read(stage, ref->hash, offset, VF_BLOB_CHUNK_BYTES, &bytes, &len, &size)) != VF_OK)
      break;
    if (size != total || (len == 0 && offset < total)) {
      free(bytes);
      err = vf_error_set(VF_EIO, "file '%s' changed while being sent", ref->name);
      break;
    }
    Vcmfarm__BlobPut put = VCMFARM__BLOB_PUT__INIT;
    put.hash = (ProtobufCBinaryData){32, (uint8_t *)ref->hash};
    put.data = (ProtobufCBinaryData){len, bytes};
    put.offset = offset;
    put.total_size = total;
    put.transfer_id = transfer;
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *ack = NULL;
    q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_PUT;
    q.blob_put = &put;
    err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, timeout_ms, &ack);
    if (err == VF_OK && !ack->result_ack->accepted)
      err = vf_error_set(VF_EREFUSED, "file '%s': %s", ref->name, ack->result_ack->message);
    else if (err != VF_OK)
      err = vf_error_set(err, "sending file '%s': %s", ref->name, vf_error_detail(err));
    vf_message_free(ack);
    free(bytes);
    offset += len;
  } while (err == VF_OK && offset < total);
  return err;
}

/* Sends the files the coordinator does not hold yet, one at a time and each in chunks: a
 * job's files together may exceed the frame cap, and so may one file. */
static int send_files(vf_farm_client *client, int timeout_ms, const char *log_prefix, const char *stage,
                      const vf_blob_table *files) {
  ProtobufCBinaryData *hashes = calloc(files->count, sizeof *hashes);
  if (hashes == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  for (size_t i = 0; i < files->count; i++) hashes[i] = (ProtobufCBinaryData){32, files->refs[i].hash};
  Vcmfarm__BlobQuery query = VCMFARM__BLOB_QUERY__INIT;
  query.n_hashes = files->count;
  query.hashes = hashes;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *have = NULL;
  q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_QUERY;
  q.blob_query = &query;
  int err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_BLOB_HAVE, timeout_ms, &have);
  free(hashes);
  if (err != VF_OK) return err;
  /* Big chunks take a while on slow links: at least two minutes each. */
  int slow_ms = timeout_ms > 120000 ? timeout_ms : 120000;
  uint64_t bytes_sent = 0;
  size_t sent = 0;
  for (size_t i = 0; i < files->count && err == VF_OK; i++) {
    const vf_blob_ref *ref = &files->refs[i];
    int missing = 0;
    for (size_t k = 0; k < have->blob_have->n_missing; k++)
      missing |= have->blob_have->missing[k].len == 32 && memcmp(have->blob_have->missing[k].data, ref->hash, 32) == 0;
    int earlier = 0; /* two names with the same content: one blob */
    for (size_t k = 0; k < i; k++) earlier |= memcmp(files->refs[k].hash, ref->hash, 32) == 0;
    if (!missing || earlier) continue;
    if ((err = send_blob(client, slow_ms, stage, ref)) == VF_OK) {
      sent++;
      bytes_sent += ref->size;
    }
  }
  if (err == VF_OK && log_prefix)
    fprintf(stderr, "%s: %zu %s named by the scene; sent %zu (%llu %s), the coordinator held the rest\n", log_prefix,
            files->count, vf_cli_plural(files->count, "file", "files"), sent, (unsigned long long)bytes_sent,
            vf_cli_plural(bytes_sent, "byte", "bytes"));
  vf_message_free(have);
  return err;
}

/* The job's name and the scene's path as the coordinator will keep them: a name of at most
 * VF_JOB_MAX_NAME bytes, a path that fits a film (511 bytes), both UTF-8 (`status --json`
 * and the film's attributes carry them). Refused here, before anything is sent. */
int vf_submit_check_texts(const vf_submit_job *job) {
  int builtin = vf_job_scene_is_builtin(job->source) && !vf_scene_is_model_file(job->source);
  const char *name = job->name ? job->name : job->source;
  size_t n = strlen(name);
  if (n > VF_JOB_MAX_NAME || !vf_utf8_valid(name, n))
    return vf_error_set(VF_EUSAGE, "the job's name%s is %s: it must be UTF-8 of at most %d bytes (--name NAME)",
                        job->name ? "" : " (the scene's path, by default)",
                        n > VF_JOB_MAX_NAME ? "too long" : "not valid UTF-8", VF_JOB_MAX_NAME);
  return builtin ? VF_OK : vf_cli_scene_path(job->source);
}

int vf_submit(vf_farm_client *client, int timeout_ms, const vf_submit_job *job, vf_submitted_job *out) {
  const char *source = job->source, *reference = job->reference;
  int err = VF_OK;
  int builtin = vf_job_scene_is_builtin(source);
  uint8_t *text = NULL;
  size_t len = 0;
  vf_blob_table reference_file = {0}, text_file = {0}, allocation_file = {0};
  uint8_t *samples = NULL; /* the job's allocation, when it ships one; owned */
  double pilot_render_seconds = 0.0, pilot_cpu_seconds = 0.0; /* auto's pilots, rendered here */
  vf_scene *scene = NULL;
  vf_image reference_image = {0};
  Vcmfarm__Envelope *reply = NULL;
  vf_blob_table files = {0};
  Vcmfarm__BlobRef *file_refs = NULL, **file_ref_ptrs = NULL;
  char stage[4096] = "";
  if ((err = vf_submit_check_texts(job)) != VF_OK) return err;
  if (job->camera != NULL && !vf_scene_is_model_file(source))
    return vf_error_set(VF_EUSAGE, "--camera chooses a camera of a glTF or OBJ file or a Mitsuba scene's sensor; a JSON scene chooses it in "
                        "import[i].camera (docs/SCENES.md)");
  if (vf_scene_is_model_file(source)) {
    /* A model file travels as the JSON scene that imports it (a Mitsuba scene as the JSON
     * scene it converts to): its files (buffers, .mtl, textures, meshes) are then recorded
     * and shipped like any JSON scene's. */
    char *model_text;
    if ((err = vf_scene_model_text(source, job->camera, &model_text, &len)) != VF_OK) return err;
    text = (uint8_t *)model_text;
    builtin = 0;
  } else if (builtin) {
    len = strlen(source);
  } else if ((err = vf_file_read_all(source, 16u << 20, &text, &len)) != VF_OK) {
    return vf_scene_not_found(source, err);
  }
  /* Load it as the workers will, to refuse a broken scene here and learn its hash; a JSON
   * scene's files are collected as blobs on the way. */
  if (builtin) err = vf_job_scene_load(1, source, len, NULL, NULL, source, &scene);
  else if ((err = vf_file_temp_dir("vcmfarm-submit", stage, sizeof stage)) == VF_OK)
    err = vf_job_scene_collect(source, (const char *)text, len, stage, &files, &scene);
  if (err != VF_OK) goto done;
  vf_cli_print_notes(scene->source, scene->notes);
  vf_settings settings = scene->settings;
  if (job->overrides && (err = vf_cli_settings_apply(job->overrides, &settings)) != VF_OK) goto done;
  if (job->allocation_from &&
      (err = vf_render_job_allocation_from(job->allocation_from, scene->hash, job->overrides ? job->overrides->pilot : -1, &settings,
                                           &samples)) != VF_OK)
    goto done;
  char settings_text[512];
  if ((err = vf_settings_validate(&settings)) != VF_OK) goto done;
  if (samples == NULL && vf_settings_choose_by_pilots(&settings)) {
    /* auto with a pilot is decided here, once, by the candidates' pilots on this machine
     * (vf_render_choose_algorithm): the job names the algorithm it chose and carries the
     * allocation it chose, which the farm could not compute again (it may combine several
     * candidates' pilots). */
    vf_auto_choice choice;
    if ((samples = malloc((size_t)settings.width * (size_t)settings.height)) == NULL) {
      err = vf_error_set(VF_ENOMEM, "out of memory for an allocation of %dx%d", settings.width, settings.height);
      goto done;
    }
    if ((err = vf_render_choose_algorithm(scene, &settings, 0, NULL, samples, &choice)) != VF_OK) goto done;
    pilot_render_seconds = choice.render_seconds;
    pilot_cpu_seconds = choice.cpu_seconds;
    if (job->log_prefix) vf_render_job_print_choice(&choice, settings.pilot);
  }
  if (samples != NULL) {
    /* The allocation travels as a blob, as the reference does: one opaque byte a pixel. */
    size_t n = (size_t)settings.width * (size_t)settings.height;
    uint8_t hash[32];
    vf_blob_hash(samples, n, hash);
    if ((!stage[0] && (err = vf_file_temp_dir("vcmfarm-submit", stage, sizeof stage)) != VF_OK) ||
        (err = vf_blob_store_put(stage, hash, samples, n)) != VF_OK ||
        (err = vf_blob_table_add(&allocation_file, "allocation", hash, n)) != VF_OK)
      goto done;
  }
  if ((err = vf_settings_format(&settings, settings_text, sizeof settings_text)) != VF_OK) goto done;

  /* The reference is read here too, so a wrong one is refused before anything is sent. */
  if (reference) {
    if ((err = vf_image_read_exr(reference, &reference_image)) != VF_OK) goto done;
    if (reference_image.width != settings.width || reference_image.height != settings.height) {
      err = vf_error_set(VF_EMISMATCH, "reference %s is %dx%d, the job renders %dx%d", reference,
                         reference_image.width, reference_image.height, settings.width, settings.height);
      goto done;
    }
    /* It travels as a blob, like the scene's files: any size. */
    uint8_t *bytes, hash[32];
    size_t n;
    if ((!stage[0] && (err = vf_file_temp_dir("vcmfarm-submit", stage, sizeof stage)) != VF_OK) ||
        (err = vf_file_read_all(reference, (size_t)VF_BLOB_MAX_BYTES, &bytes, &n)) != VF_OK)
      goto done;
    vf_blob_hash(bytes, n, hash);
    err = vf_blob_store_put(stage, hash, bytes, n);
    free(bytes);
    if (err != VF_OK || (err = vf_blob_table_add(&reference_file, "reference", hash, n)) != VF_OK) goto done;
  }
  Vcmfarm__Scene s = VCMFARM__SCENE__INIT;
  Vcmfarm__BlobRef text_ref = VCMFARM__BLOB_REF__INIT;
  if (builtin) {
    s.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
    s.builtin = (char *)source;
  } else if (len <= VF_WIRE_MAX_INLINE_SCENE) {
    s.source_case = VCMFARM__SCENE__SOURCE_JSON;
    s.json = (char *)text;
  } else {
    /* A long text goes first as a blob, so that the submission stays under the
     * coordinator's request cap (docs/PROTOCOL.md, "What a peer without the key costs"). */
    uint8_t hash[32];
    vf_blob_hash(text, len, hash);
    if ((!stage[0] && (err = vf_file_temp_dir("vcmfarm-submit", stage, sizeof stage)) != VF_OK) ||
        (err = vf_blob_store_put(stage, hash, text, len)) != VF_OK ||
        (err = vf_blob_table_add(&text_file, "scene text", hash, len)) != VF_OK ||
        (err = send_files(client, timeout_ms, NULL, stage, &text_file)) != VF_OK)
      goto done;
    text_ref.name = text_file.refs[0].name;
    text_ref.hash = (ProtobufCBinaryData){32, text_file.refs[0].hash};
    text_ref.size = len;
    s.source_case = VCMFARM__SCENE__SOURCE_JSON_BLOB;
    s.json_blob = &text_ref;
  }
  if (files.count > 0) {
    if ((err = send_files(client, timeout_ms, job->log_prefix, stage, &files)) != VF_OK ||
        (err = vf_blob_table_to_wire(&files, &file_refs, &file_ref_ptrs)) != VF_OK)
      goto done;
    s.n_files = files.count;
    s.files = file_ref_ptrs;
  }
  Vcmfarm__BlobRef reference_ref = VCMFARM__BLOB_REF__INIT;
  if (reference_file.count > 0) {
    if ((err = send_files(client, timeout_ms, NULL, stage, &reference_file)) != VF_OK) goto done;
    reference_ref.name = reference_file.refs[0].name;
    reference_ref.hash = (ProtobufCBinaryData){32, reference_file.refs[0].hash};
    reference_ref.size = reference_file.refs[0].size;
  }
  Vcmfarm__BlobRef allocation_ref = VCMFARM__BLOB_REF__INIT;
  if (allocation_file.count > 0) {
    if ((err = send_files(client, timeout_ms, NULL, stage, &allocation_file)) != VF_OK) goto done;
    allocation_ref.name = allocation_file.refs[0].name;
    allocation_ref.hash = (ProtobufCBinaryData){32, allocation_file.refs[0].hash};
    allocation_ref.size = allocation_file.refs[0].size;
  }
  Vcmfarm__SubmitJob m = VCMFARM__SUBMIT_JOB__INIT;
  m.name = (char *)(job->name ? job->name : source);
  m.scene = &s;
  m.scene_hash.data = scene->hash;
  m.scene_hash.len = 32;
  m.settings = settings_text;
  m.first_iteration = job->first;
  char scene_path[PATH_MAX] = "";
  if (!builtin && realpath(source, scene_path) == NULL) scene_path[0] = '\0';
  m.scene_path = scene_path;
  m.iterations = job->iterations;
  m.priority = (int32_t)job->priority;
  char *requires[VF_TAGS_MAX];
  for (unsigned i = 0; job->requires != NULL && i < job->requires->count; i++)
    requires[m.n_requires++] = (char *)job->requires->tag[i];
  m.requires = requires;
  m.time_limit = job->time_limit;
  m.target_rmse = job->target_rmse;
  m.target_error = job->target_error;
  if (reference_file.count > 0) m.reference = &reference_ref;
  if (allocation_file.count > 0) {
    m.allocation = &allocation_ref;
    m.pilot_render_seconds = pilot_render_seconds; /* the film counts them, as render's does */
    m.pilot_cpu_seconds = pilot_cpu_seconds;
  }
  /* The renderer's own rule, so that status shows what every worker will render. */
  if (vf_algorithm_is_auto(settings.algorithm))
    m.algorithm_resolved = (char *)vf_algorithm_name(vf_vcm_auto_algorithm(scene, settings.algorithm, NULL));
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &m;
  if ((err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_SUBMITTED, timeout_ms, &reply)) != VF_OK) goto done;
  out->job_id = reply->submitted->job_id;
  out->settings = settings;
  snprintf(out->settings_text, sizeof out->settings_text, "%s", settings_text);
  snprintf(out->scene_source, sizeof out->scene_source, "%s", scene->source);
done:
  if (stage[0]) vf_file_remove_tree(stage); /* the scene's files as blobs */
  free(file_refs);
  free(file_ref_ptrs);
  vf_blob_table_clear(&files);
  vf_blob_table_clear(&reference_file);
  vf_blob_table_clear(&text_file);
  vf_blob_table_clear(&allocation_file);
  free(samples);
  vf_message_free(reply);
  vf_scene_destroy(scene);
  vf_image_destroy(&reference_image);
  free(text);
  return err;
}
