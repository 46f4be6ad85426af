/* `vcmfarm worker`: the command line of the farm worker (worker/worker.h). */
#include "worker_cmd.h"

#include "interrupt.h"
#include "options.h"
#include "../common/error.h"
#include "../worker/blob_cache.h"
#include "../worker/worker.h"

#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage[] =
    "usage: vcmfarm worker --connect URL --secret FILE [options]\n"
    "\n"
    "Renders leases of global iterations for the coordinator at URL until SIGTERM or\n"
    "SIGINT, then hands back the lease it holds and exits. Reconnects with backoff when\n"
    "the coordinator is away.\n"
    "\n"
    "  -c, --connect URL     the coordinator: tcp://HOST:PORT or ipc://PATH\n"
    "  -k, --secret FILE     the farm's key file (vcmfarm keygen); required\n"
    "  -j, --threads T       render threads (default: one per CPU)\n"
    "  -n, --name NAME       name shown in status (default HOST/PID)\n"
    "      --tags TAG[,TAG]  tags of this worker (a pool, a room, a licence: night,gpu-room);\n"
    "                        jobs submitted with --require are leased only to workers\n"
    "                        satisfying all they require. At most 16 tags of 1 to 32\n"
    "                        bytes of UTF-8, no spaces or commas; given once or in several\n"
    "                        options. Found ones are added: avx2, avx512 from the CPU,\n"
    "                        and the machine's memory is told for mem>=N requirements\n"
    "      --no-auto-tags    add no CPU tags (the memory is still told)\n"
    "      --ship-interval S  send the iterations rendered so far every S seconds during\n"
    "                        a lease (default: as often as the coordinator says, which\n"
    "                        it chooses from its load and the film's size; longer when\n"
    "                        sending takes more than 2% of the time), and the rest at its end\n"
    "      --cache DIR       cache of scene files fetched from the coordinator (default\n"
    "                        $XDG_CACHE_HOME/vcmfarm, else ~/.cache/vcmfarm)\n"
    "      --cache-max SIZE  keep the cache at most SIZE bytes (suffix K, M, G or T):\n"
    "                        after fetching a job's files, the blobs used least recently\n"
    "                        go first, never the job's own (default: no limit)\n"
    "  -h, --help            this text\n"
    "\n"
    "For tests only:\n"
    "      --test-iteration-delay MS  sleep MS after every iteration (slows leases down)\n"
    "      --test-stall-file PATH     after the first lease, create PATH.stalled and wait,\n"
    "                                 silent, until PATH exists before sending the result\n"
    "      --test-abort-scene TEXT    crash (abort) on a lease of the built-in scene TEXT or\n"
    "                                 of a JSON scene whose text contains TEXT\n";

int vf_cmd_worker(int argc, char **argv) {
  static const struct option options[] = {
      {"connect", required_argument, 0, 'c'}, {"secret", required_argument, 0, 'k'},
      {"threads", required_argument, 0, 'j'}, {"name", required_argument, 0, 'n'},
      {"test-iteration-delay", required_argument, 0, 'D'}, {"test-stall-file", required_argument, 0, 'S'},
      {"test-abort-scene", required_argument, 0, 'A'},
      {"ship-interval", required_argument, 0, 'I'},
      {"cache", required_argument, 0, 'C'},   {"cache-max", required_argument, 0, 'M'},
      {"tags", required_argument, 0, 'G'},   {"no-auto-tags", no_argument, 0, 'g'},
      {"help", no_argument, 0, 'h'},          {0, 0, 0, 0}};
  const char *cmd = "worker", *secret = NULL, *cache = NULL;
  vf_worker_config config;
  memset(&config, 0, sizeof config);
  config.ship_interval = 0.0; /* the coordinator's */
  long long threads = 0, delay = 0;
  vf_tags tags;
  vf_tags_init(&tags);
  int err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "c:k:j:n:h", options)) != -1) {
    switch (c) {
    case 'c':
      config.url = optarg;
      err = vf_cli_address("--connect", optarg);
      break;
    case 'k': secret = optarg; break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'n': config.name = optarg; break;
    case 'D': err = vf_cli_int("--test-iteration-delay", optarg, 0, 60000, &delay); break;
    case 'S': config.stall_file = optarg; break;
    case 'A': config.abort_scene = optarg; break;
    case 'I': err = vf_cli_double("--ship-interval", optarg, 0.01, 86400.0, &config.ship_interval); break;
    case 'C': cache = optarg; break;
    case 'M': err = vf_cli_bytes("--cache-max", optarg, &config.cache_max_bytes); break;
    case 'G': err = vf_tags_parse("--tags", optarg, &tags, 0); break;
    case 'g': config.no_auto_tags = 1; break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("worker");
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc || config.url == NULL || secret == NULL) {
    return vf_cli_usage_error("worker", "--connect and --secret are required, nothing else");
  }
  char cache_dir[4096];
  if (cache == NULL) err = vf_blob_cache_default_dir(cache_dir, sizeof cache_dir);
  else if (snprintf(cache_dir, sizeof cache_dir, "%s", cache) >= (int)sizeof cache_dir)
    err = vf_error_set(VF_EINVAL, "--cache: directory name too long");
  if (err == VF_OK) err = vf_blob_cache_open(cache_dir);
  if (err == VF_OK) err = vf_wire_key_load(secret, &config.key);
  if (err != VF_OK) return vf_cli_fail(cmd, err);
  config.cache_dir = cache_dir;
  config.tags = &tags;
  config.threads = (int)threads;
  config.iteration_delay_ms = (int)delay;
  srand((unsigned)getpid());
  vf_interrupt_saved saved;
  vf_interrupt_catch(&saved);
  signal(SIGPIPE, SIG_IGN);
  err = vf_worker_run(&config, &vf_interrupted);
  vf_interrupt_restore(&saved);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
