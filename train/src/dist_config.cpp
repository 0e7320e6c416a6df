// Which rank of which job this process is: torchrun's and SLURM's variables,
// overridden by the flags (docs/TRAINING.md "Data-parallel").
#include <cerrno>
#include <cstdlib>

#include "dist_internal.hpp"
#include "reefgen/error.hpp"

namespace reefgen::train {

namespace detail {

// Strict integer parse: the whole string, within [lo, hi].
int parse_int(const std::string& name, const std::string& v, long lo, long hi, const std::string& fix) {
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno || x < lo || x > hi)
    throw Error(name + "=" + v + ": not an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]; " + fix);
  return int(x);
}

std::string ranks_list(const std::vector<int>& r) {
  std::string s;
  for (size_t i = 0; i < r.size(); ++i) s += (i ? ", " : "") + std::to_string(r[i]);
  return s;
}

}  // namespace detail

using detail::parse_int;

std::string first_slurm_host(const std::string& nodelist) {
  // The first entry: up to a comma outside brackets.
  size_t depth = 0, end = nodelist.size();
  for (size_t i = 0; i < nodelist.size(); ++i) {
    if (nodelist[i] == '[') ++depth;
    if (nodelist[i] == ']' && depth) --depth;
    if (nodelist[i] == ',' && depth == 0) {
      end = i;
      break;
    }
  }
  const std::string first = nodelist.substr(0, end);
  const size_t open = first.find('[');
  if (open == std::string::npos) return first;
  const size_t close = first.find(']', open);
  if (close == std::string::npos) throw Error("SLURM_JOB_NODELIST=" + nodelist + ": unbalanced brackets; set MASTER_ADDR");
  // "03-05,09" -> "03" (zero padding kept: it is part of the host name)
  const std::string range = first.substr(open + 1, close - open - 1);
  const std::string lo = range.substr(0, range.find_first_of("-,"));
  return first.substr(0, open) + lo + first.substr(close + 1);
}

DistConfig dist_config_from(const std::function<const char*(const char*)>& getenv, const DistFlags& flags) {
  auto get = [&](const char* k) -> std::string {
    const char* v = getenv(k);
    return v ? std::string(v) : std::string();
  };
  DistConfig c;
  std::string rank_name = "RANK", world_name = "WORLD_SIZE", port_name = "MASTER_PORT";
  const std::string fix_env = "fix the launcher's environment or pass --rank/--world-size";
  if (!get("RANK").empty() || !get("WORLD_SIZE").empty()) {
    if (get("RANK").empty() || get("WORLD_SIZE").empty())
      throw Error(std::string(get("RANK").empty() ? "WORLD_SIZE" : "RANK") + " is set but " +
                  (get("RANK").empty() ? "RANK" : "WORLD_SIZE") + " is not; set both (torchrun does) or neither");
    c.source = get("REEFGEN_LAUNCHER_PID").empty() ? "torchrun's environment" : "train --nproc";
    c.world_size = parse_int("WORLD_SIZE", get("WORLD_SIZE"), 0, 4096, fix_env);
    c.rank = parse_int("RANK", get("RANK"), 0, 4095, fix_env);
    c.local_rank = get("LOCAL_RANK").empty() ? c.rank : parse_int("LOCAL_RANK", get("LOCAL_RANK"), 0, 4095, fix_env);
    c.local_world_size =
        get("LOCAL_WORLD_SIZE").empty() ? 1 : parse_int("LOCAL_WORLD_SIZE", get("LOCAL_WORLD_SIZE"), 1, 4096, fix_env);
    c.agent_store = get("TORCHELASTIC_USE_AGENT_STORE") == "True";
    if (!get("TORCHELASTIC_RESTART_COUNT").empty())
      c.restart_count = parse_int("TORCHELASTIC_RESTART_COUNT", get("TORCHELASTIC_RESTART_COUNT"), 0, 1 << 30, fix_env);
  } else if (!get("SLURM_PROCID").empty() && !get("SLURM_NTASKS").empty()) {
    c.source = "SLURM's environment";
    rank_name = "SLURM_PROCID";
    world_name = "SLURM_NTASKS";
    c.world_size = parse_int("SLURM_NTASKS", get("SLURM_NTASKS"), 0, 4096, "run under srun or pass --world-size");
    c.rank = parse_int("SLURM_PROCID", get("SLURM_PROCID"), 0, 4095, "run under srun or pass --rank");
    if (!get("SLURM_LOCALID").empty()) c.local_rank = parse_int("SLURM_LOCALID", get("SLURM_LOCALID"), 0, 4095, fix_env);
    // "2(x3),1" -> 2 tasks on the first node; ours may be another, but jobs are usually uniform.
    const std::string per = !get("SLURM_NTASKS_PER_NODE").empty() ? get("SLURM_NTASKS_PER_NODE") : get("SLURM_TASKS_PER_NODE");
    if (!per.empty()) c.local_world_size = std::max(1, std::atoi(per.c_str()));
    const std::string nodes = !get("SLURM_JOB_NODELIST").empty() ? get("SLURM_JOB_NODELIST") : get("SLURM_NODELIST");
    if (get("MASTER_ADDR").empty()) {
      if (nodes.empty()) throw Error("SLURM_JOB_NODELIST is not set; set MASTER_ADDR to the first node's host name");
      c.master_addr = first_slurm_host(nodes);
    }
  }
  if (!get("MASTER_ADDR").empty()) c.master_addr = get("MASTER_ADDR");
  if (!get("MASTER_PORT").empty())
    c.master_port = parse_int("MASTER_PORT", get("MASTER_PORT"), 1, 65535, "choose a free TCP port");
  if (flags.rank >= 0) c.rank = flags.rank, rank_name = "--rank";
  if (flags.world_size >= 0) c.world_size = flags.world_size, world_name = "--world-size";
  if (!flags.master_addr.empty()) c.master_addr = flags.master_addr;
  if (flags.master_port >= 0) c.master_port = flags.master_port, port_name = "--master-port";
  if (flags.timeout_s >= 0) c.timeout_s = flags.timeout_s;
  if (flags.rank >= 0 || flags.world_size >= 0) c.source = "the flags";
  if (c.world_size < 1)
    throw Error(world_name + "=" + std::to_string(c.world_size) + ": a job has at least one rank; " + fix_env);
  if (c.rank >= c.world_size)
    throw Error(rank_name + "=" + std::to_string(c.rank) + " with " + world_name + "=" + std::to_string(c.world_size) +
                ": ranks are 0.." + std::to_string(c.world_size - 1) + "; " + fix_env);
  if (c.master_port < 1 || c.master_port > 65535)
    throw Error(port_name + "=" + std::to_string(c.master_port) + ": not a TCP port; choose one in [1, 65535]");
  if (!(c.timeout_s > 0 && c.timeout_s <= 86400))
    throw Error("--dist-timeout " + std::to_string(c.timeout_s) + ": must be in (0, 86400] seconds");
  if (c.local_rank >= c.local_world_size) c.local_world_size = c.local_rank + 1;
  return c;
}

}  // namespace reefgen::train
