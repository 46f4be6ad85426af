/* The coordinator keeps answering while it checkpoints a big film (coordinator/checkpoint.h).
 *
 *   test_farm_checkpoint VCMFARM
 *
 * Prepares a state directory holding one 1920x1080 job whose film is noise (190 MB: about
 * 0.3 s to write and sync here, 5 s while films were ZIP) with iteration 0 done, starts the
 * real `vcmfarm coordinator` on it, and merges one result (iteration 1) as a worker would,
 * which makes the film due for a checkpoint. Then it asks for the status back to back and
 * times every reply while the coordinator writes the film; the write is watched through its
 * temporary file (job-1.exr.tmp.PID) appearing and then being renamed away.
 *
 * Passes when the write was seen, at least MIN_ANSWERED status replies were both sent and
 * received while the temporary file existed, and no reply took longer than MAX_LATENCY_MS;
 * then, after SIGTERM, the coordinator exits 0 and the film on disk holds exactly
 * iterations [0,2): the merged result counted once, nothing lost. With the film written on
 * the event loop no reply is answered during the write (the loop is busy writing) and the
 * latest takes as long as the write. */
#include "common/error.h"
#include "common/farm_client.h"
#include "common/film.h"
#include "common/film_wire.h"
#include "common/settings.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define WIDTH 1920
#define HEIGHT 1080
#define MIN_ANSWERED 5
#define MAX_LATENCY_MS 1000.0

extern char **environ;
static int failures;

static void expect(int cond, const char *what) {
  printf("%s %s\n", cond ? "ok  " : "FAIL", what);
  fflush(stdout);
  if (!cond) failures++;
}

static double now_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

static int write_text(const char *path, const char *text) {
  FILE *f = fopen(path, "w");
  if (f == NULL) return -1;
  int ok = fputs(text, f) >= 0;
  return fclose(f) == 0 && ok ? 0 : -1;
}

/* Noise in every accumulation channel, iteration 0 done: slow to compress. */
static int noisy_film(const char *settings, const uint8_t hash[32], vf_film **out) {
  vf_film *film;
  int err = vf_film_create(WIDTH, HEIGHT, &film);
  if (err != VF_OK) return err;
  memcpy(film->scene_hash, hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  uint64_t x = 0x9e3779b97f4a7c15ull;
  size_t n = (size_t)WIDTH * HEIGHT;
  for (size_t i = 0; i < 3 * n; i++) {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    double c = (double)(x >> 11) * 0x1p-53;
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    double l = (double)(x >> 11) * 0x1p-53;
    film->sum[i] = vf_fixed_from_double(c + l, VF_FILM_SUM_BITS);
    film->square_sum[i] = vf_fixed_from_double((c + l) * (c + l), VF_FILM_SQUARE_BITS);
  }
  if ((err = vf_iterset_add(&film->iterations, 0, 1)) != VF_OK) {
    vf_film_destroy(film);
    return err;
  }
  *out = film;
  return VF_OK;
}

/* 1 while a temporary file of the job's film exists in the state directory. */
static int writing(const char *state) {
  DIR *d = opendir(state);
  if (d == NULL) return 0;
  struct dirent *e;
  int found = 0;
  while (!found && (e = readdir(d)) != NULL) found = strncmp(e->d_name, "job-1.exr.tmp.", 14) == 0;
  closedir(d);
  return found;
}

static char refusal[1024];

/* One message of tiles: 1 accepted, 0 refused (the reason in `refusal`), < 0 not sent. */
static int send_tiles(void *ctx, Vcmfarm__LeaseResult *m) {
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  int err = vf_farm_request(ctx, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 60000, &reply);
  /* "busy" (protocol 7): the merge queue is full, the same message again after retry_ms */
  for (int tries = 0; err == VF_OK && !reply->result_ack->accepted && reply->result_ack->retry_ms > 0 && tries < 1000;
       tries++) {
    usleep(1000u * reply->result_ack->retry_ms);
    vf_message_free(reply);
    err = vf_farm_request(ctx, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 60000, &reply);
  }
  if (err != VF_OK) return err;
  int accepted = reply->result_ack->accepted;
  snprintf(refusal, sizeof refusal, "%s", reply->result_ack->message);
  vf_message_free(reply);
  return accepted;
}

static int merge_one_result(vf_farm_client *c, const char *settings, const uint8_t hash[32]) {
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "test_farm_checkpoint";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  int err = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, 20000, &reply);
  if (err != VF_OK) return err;
  uint64_t worker_id = reply->registered->worker_id;
  vf_message_free(reply);
  Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
  lr.worker_id = worker_id;
  q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
  q.lease_request = &lr;
  if ((err = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_LEASE, 20000, &reply)) != VF_OK) return err;
  uint64_t lease_id = reply->lease->lease_id, begin = reply->lease->begin, end = reply->lease->end;
  vf_message_free(reply);
  /* The worker's rate is unknown: a lease bounded by time, of which [1,2) is sent as a part. */
  if (begin != 1 || end < 2) return vf_error_set(VF_EINVAL, "expected a lease from 1, got [%llu,%llu)",
                                                 (unsigned long long)begin, (unsigned long long)end);
  vf_film *film;
  if ((err = vf_film_create(WIDTH, HEIGHT, &film)) != VF_OK) return err;
  memcpy(film->scene_hash, hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  float *zeros = calloc(3 * (size_t)WIDTH * HEIGHT, sizeof *zeros);
  if (zeros == NULL) err = VF_ENOMEM;
  if (err == VF_OK) err = vf_film_add_iteration(film, 1, zeros, zeros, NULL);
  free(zeros);
  if (err == VF_OK) {
    Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
    m.worker_id = worker_id;
    m.lease_id = lease_id;
    m.job_id = 1;
    m.begin = 1;
    int rc = vf_film_send_tiles(film, &m, 10, send_tiles, c);
    if (rc != 1) err = rc < 0 ? rc : vf_error_set(VF_EREFUSED, "%s", refusal);
  }
  vf_film_destroy(film);
  return err;
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: test_farm_checkpoint VCMFARM\n");
    return 2;
  }
  char dir[] = "/tmp/vf-checkpoint-XXXXXX", state[256], path[512], url[300], key_path[300], log_path[300];
  if (mkdtemp(dir) == NULL) return 1;
  snprintf(state, sizeof state, "%s/state", dir);
  snprintf(url, sizeof url, "ipc://%s/coordinator.sock", dir);
  snprintf(key_path, sizeof key_path, "%s/farm.key", dir);
  snprintf(log_path, sizeof log_path, "%s/coordinator.log", dir);
  mkdir(state, 0700);

  vf_settings s;
  vf_settings_default(&s);
  s.width = WIDTH;
  s.height = HEIGHT;
  char settings[512], hex[65];
  uint8_t hash[32];
  for (int i = 0; i < 32; i++) hash[i] = (uint8_t)(17 * i + 3);
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", hash[i]);
  vf_wire_key key;
  vf_film *film = NULL;
  int err = vf_settings_format(&s, settings, sizeof settings);
  if (err == VF_OK) err = vf_wire_key_generate(key_path);
  if (err == VF_OK) err = vf_wire_key_load(key_path, &key);
  if (err == VF_OK) err = noisy_film(settings, hash, &film);
  snprintf(path, sizeof path, "%s/job-1.exr", state);
  double t0 = now_ms();
  if (err == VF_OK) err = vf_film_write(film, path);
  printf("     writing the 1920x1080 noisy film here took %.0f ms\n", now_ms() - t0);
  vf_film_destroy(film);
  char json[2048];
  snprintf(json, sizeof json,
           "{\"format\": 2, \"next_job_id\": 2, \"jobs\": [{\"id\": 1, \"name\": \"big\", \"priority\": 1,"
           " \"scene_builtin\": true, \"scene_hash\": \"%s\", \"settings\": \"%s\", \"iterations\": 100,"
           " \"time_limit\": 0, \"target_rmse\": 0, \"target_error\": 0, \"reference\": false, \"seconds\": 0,"
           " \"end\": \"active\", \"message\": \"\"}]}",
           hex, settings);
  char scene_path[512], index_path[512];
  snprintf(scene_path, sizeof scene_path, "%s/job-1.scene", state);
  snprintf(index_path, sizeof index_path, "%s/state.json", state);
  if (err != VF_OK || write_text(scene_path, "cornell") != 0 || write_text(index_path, json) != 0) {
    fprintf(stderr, "test_farm_checkpoint: preparing the state: %s\n", vf_error_detail(err));
    return 1;
  }

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_path, O_WRONLY | O_CREAT | O_APPEND, 0600);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  char *args[] = {argv[1], "coordinator", "--listen", url, "--state", state, "--secret", key_path,
                  "--checkpoint-interval", "0.5", NULL};
  pid_t coordinator;
  int spawned = posix_spawn(&coordinator, argv[1], &actions, NULL, args, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    errno = spawned; /* posix_spawn returns its error instead of setting errno */
    perror("posix_spawn");
    return 1;
  }
  vf_farm_client *c;
  if ((err = vf_farm_client_open(url, &key, &c)) != VF_OK) return 1;
  err = merge_one_result(c, settings, hash);
  expect(err == VF_OK, "a worker's result of iteration 1 is merged into the 1920x1080 job");
  if (err != VF_OK) printf("     %s\n", vf_error_detail(err));

  /* Status back to back until a write of the film was seen to start and to end. */
  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &sr;
  int seen = 0, done = 0, answered = 0, replies = 0;
  double max_latency = 0.0, max_during = 0.0, write_start = 0.0, write_end = 0.0, deadline = now_ms() + 60000.0;
  while (err == VF_OK && !done && now_ms() < deadline) {
    int before = writing(state);
    double t = now_ms();
    int rc = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_STATUS, 20000, &reply);
    double latency = now_ms() - t;
    int after = writing(state);
    if (rc != VF_OK) {
      printf("     status: %s\n", vf_error_detail(rc));
      break;
    }
    vf_message_free(reply);
    replies++;
    if (latency > max_latency) max_latency = latency;
    if (before || after) {
      if (!seen) write_start = t;
      seen = 1;
      if (latency > max_during) max_during = latency;
    }
    if (before && after) answered++;
    if (seen && !after) {
      done = 1;
      write_end = now_ms();
    }
  }
  printf("     %d status replies; the film write was watched for %.0f ms; %d replies were sent and received during it; "
         "max latency %.1f ms during it, %.1f ms overall\n",
         replies, write_end - write_start, answered, max_during, max_latency);
  expect(seen && done, "the coordinator wrote the job's film (its temporary file came and went)");
  expect(answered >= MIN_ANSWERED, "status requests were answered while the film was being written");
  expect(max_latency <= MAX_LATENCY_MS, "no status reply took more than 1 s");

  kill(coordinator, SIGTERM);
  int status = -1;
  waitpid(coordinator, &status, 0);
  expect(WIFEXITED(status) && WEXITSTATUS(status) == 0, "the coordinator stops cleanly on SIGTERM");
  vf_film *back = NULL;
  char set[64] = "";
  if (vf_film_read(path, &back) == VF_OK) vf_iterset_format(&back->iterations, set, sizeof set);
  printf("     the checkpointed film holds %s\n", set);
  expect(strcmp(set, "[0,2)") == 0, "the film on disk holds exactly [0,2)");
  vf_film_destroy(back);
  vf_farm_client_close(c);
  if (failures) {
    printf("---- %s\n", log_path);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "tail -n 30 %s", log_path);
    if (system(cmd) != 0) printf("(no log)\n");
  } else {
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0) printf("could not remove %s\n", dir);
  }
  return failures ? 1 : 0;
}
