#include "coordinator_cmd.h"

#include "options.h"
#include "status_report.h"
#include "../common/error.h"
#include "../coordinator/coordinator.h"

#include <getopt.h>
#include <stdio.h>

static const char usage[] =
    "usage: vcmfarm coordinator --listen URL --state DIR --secret FILE [options]\n"
    "\n"
    "Serves a render farm: accepts jobs (vcmfarm submit), hands out leases of global\n"
    "iterations to workers (vcmfarm worker), merges their films, and checkpoints every\n"
    "job to DIR so that a restart on the same DIR resumes them. See docs/PROTOCOL.md.\n"
    "\n"
    "  -l, --listen URL             where to listen: tcp://HOST:PORT (HOST an address, a name or *)\n"
    "                               or ipc://PATH\n"
    "  -d, --state DIR              state directory (created if missing; one coordinator at a time)\n"
    "  -k, --secret FILE            the farm's key file (vcmfarm keygen FILE); required\n"
    "  -w, --worker-timeout S       a worker silent for S seconds is lost (default 15); a pause of\n"
    "                               the coordinator itself does not count, and its silence counts\n"
    "                               against a worker only while others are heard. Also the grace\n"
    "                               period (at least 5 s) in which a job at its time limit\n"
    "                               merges its workers' final parts\n"
    "      --lease-seconds S        target duration of a lease (default 20)\n"
    "      --checkpoint-interval S  seconds between film checkpoints (default 10)\n"
    "      --forgive S              a worker whose lease of a job failed is not handed that job\n"
    "                               again for S seconds (default 300; docs/PROTOCOL.md)\n"
    "      --max-connections N      tcp://: connections at once (default 4096); one more is\n"
    "                               refused at once (docs/PROTOCOL.md)\n"
    "      --max-in-flight MIB      tcp://: MiB of requests held at once, over all connections\n"
    "                               (default 256; at least 5); the rest wait, unread\n"
    "      --http [HOST:]PORT       serve the web dashboard there (HOST 127.0.0.1 unless given;\n"
    "                               another address only when given; actions need the key)\n"
    "  -h, --help                   this text\n"
    "\n"
    "Stops on SIGINT or SIGTERM after a final checkpoint. Exit status: 0 after a clean stop,\n"
    "1 failure, 2 bad input.\n";

int vf_cmd_coordinator(int argc, char **argv) {
  static const struct option options[] = {
      {"listen", required_argument, 0, 'l'},         {"state", required_argument, 0, 'd'},
      {"secret", required_argument, 0, 'k'},         {"worker-timeout", required_argument, 0, 'w'},
      {"lease-seconds", required_argument, 0, 'L'},  {"checkpoint-interval", required_argument, 0, 'C'},
      {"http", required_argument, 0, 'H'},           {"help", no_argument, 0, 'h'},
      {"forgive", required_argument, 0, 'F'},        {"max-connections", required_argument, 0, 'M'},
      {"max-in-flight", required_argument, 0, 'B'},
      {0, 0, 0, 0}};
  const char *cmd = "coordinator";
  vf_coordinator_config config = {.worker_timeout = 15.0, .lease_seconds = 20.0, .checkpoint_interval = 10.0, .forgive_seconds = 300.0,
                                  .handle_signals = 1, .status_json = vf_status_json_text};
  int err = VF_OK, c;
  long long n;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "l:d:k:w:h", options)) != -1) {
    switch (c) {
    case 'l':
      config.listen_url = optarg;
      err = vf_cli_address("--listen", optarg);
      break;
    case 'd': config.state_dir = optarg; break;
    case 'k': config.secret_path = optarg; break;
    case 'w': err = vf_cli_double("--worker-timeout", optarg, 0.1, 86400.0, &config.worker_timeout); break;
    case 'L': err = vf_cli_double("--lease-seconds", optarg, 0.01, 86400.0, &config.lease_seconds); break;
    case 'C': err = vf_cli_double("--checkpoint-interval", optarg, 0.1, 86400.0, &config.checkpoint_interval); break;
    case 'F': err = vf_cli_double("--forgive", optarg, 0.0, 31536000.0, &config.forgive_seconds); break;
    case 'H': config.http_address = optarg; break;
    case 'M':
      if ((err = vf_cli_int("--max-connections", optarg, 1, 1000000, &n)) == VF_OK) config.max_connections = (size_t)n;
      break;
    case 'B':
      if ((err = vf_cli_int("--max-in-flight", optarg, 5, 1 << 20, &n)) == VF_OK) config.max_in_flight = (size_t)n << 20;
      break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("coordinator");
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc || !config.listen_url || !config.state_dir || !config.secret_path) {
    return vf_cli_usage_error("coordinator", "--listen, --state and --secret are required, nothing else");
  }
  err = vf_coordinator_run(&config);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
