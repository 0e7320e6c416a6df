#include "reefgen/train/checkpoint.hpp"

#include <fstream>
#include <sstream>

#include "reefgen/error.hpp"
#include "reefgen/files.hpp"
#include "reefgen/model/archive.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/sha256.hpp"
#include "reefgen/train/fused_adam.hpp"
#include "reefgen/version.hpp"

namespace reefgen::train {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr const char* kCheckpointFormat = "reefgen-checkpoint";
constexpr int64_t kCheckpointVersion = 1;
}  // namespace

// Settings that may change between an interrupted run and its resumption
// without changing the result. The batch may be split over another number
// of ranks: what matters is the global batch.
json comparable_config(const TrainParams& p, int64_t world_size) {
  json j = p;
  for (const char* k : {"threads", "loader_threads", "prefetch", "batch_size"}) j.erase(k);
  j["global_batch"] = int64_t(p.batch_size) * world_size;
  return j;
}

namespace {

// SHA-256 of everything a resume restores: G and D (weights and buffers),
// both Adam states in parameter order, the step, the log window and the RNG.
// Stored in the checkpoint and recomputed from what was loaded, so a file with
// flipped bytes (the zip's own CRCs are not checked by LibTorch) is refused.
std::string checkpoint_sha256(Pix2Pix& p, int64_t step, const torch::Tensor& window, const torch::Tensor& rng) {
  Sha256 h;
  h.update(model::weights_sha256(*p.G()));
  h.update(model::weights_sha256(*p.D()));
  auto tensor = [&](const torch::Tensor& t0) {
    if (!t0.defined()) return h.update("-");
    const torch::Tensor t = t0.contiguous();
    for (int64_t d : t.sizes()) h.update(&d, sizeof d);
    h.update(t.data_ptr(), size_t(t.numel() * t.element_size()));
  };
  for (torch::optim::Optimizer* opt : {static_cast<torch::optim::Optimizer*>(&p.opt_G()),
                                       static_cast<torch::optim::Optimizer*>(&p.opt_D())}) {
    for (auto& group : opt->param_groups())
      for (auto& param : group.params()) {
        const torch::optim::AdamParamState* found = adam_state(*opt, param);
        if (!found) {
          h.update("no-state");
          continue;
        }
        const torch::optim::AdamParamState& st = *found;
        const int64_t n = st.step();
        h.update(&n, sizeof n);
        tensor(st.exp_avg());
        tensor(st.exp_avg_sq());
        tensor(st.max_exp_avg_sq());
      }
  }
  h.update(&step, sizeof step);
  tensor(window);
  tensor(rng);
  return h.hex();
}

}  // namespace

namespace {

// Adam's state by the parameter's position in the optimizer (LibTorch's own
// save keys it by the parameters' memory addresses, so two identical runs
// wrote different bytes): step_K, exp_avg_K, exp_avg_sq_K (max_exp_avg_sq_K
// with amsgrad) and `params`, the count. Param-group options are not stored:
// the run's config sets them and the learning rate is set every step.
void save_adam(torch::optim::Adam& opt, torch::serialize::OutputArchive& out) {
  int64_t k = 0;
  for (auto& group : opt.param_groups())
    for (auto& param : group.params()) {
      const std::string key = std::to_string(k++);
      const torch::optim::AdamParamState* found = adam_state(opt, param);
      if (!found) continue;  // no step taken for it yet
      const torch::optim::AdamParamState& st = *found;
      out.write("step_" + key, torch::tensor(st.step(), torch::kInt64));
      out.write("exp_avg_" + key, st.exp_avg());
      out.write("exp_avg_sq_" + key, st.exp_avg_sq());
      if (st.max_exp_avg_sq().defined()) out.write("max_exp_avg_sq_" + key, st.max_exp_avg_sq());
    }
  out.write("params", c10::IValue(k));
}

// The inverse; checkpoints written before save_adam hold LibTorch's layout.
void load_adam(torch::optim::Adam& opt, torch::serialize::InputArchive& in, const fs::path& path) {
  c10::IValue count;
  if (!in.try_read("params", count)) return opt.load(in);
  int64_t k = 0;
  opt.state().clear();
  for (auto& group : opt.param_groups())
    for (auto& param : group.params()) {
      const std::string key = std::to_string(k++);
      torch::Tensor step, m, v, vmax;
      if (!in.try_read("step_" + key, step)) continue;
      auto st = std::make_unique<torch::optim::AdamParamState>();
      st->step(step.item<int64_t>());
      in.read("exp_avg_" + key, m);
      in.read("exp_avg_sq_" + key, v);
      if (m.sizes() != param.sizes() || v.sizes() != param.sizes())
        throw Error(path.string() + ": optimizer state " + key + " does not fit the network; start a new run");
      st->exp_avg(m.clone());
      st->exp_avg_sq(v.clone());
      if (in.try_read("max_exp_avg_sq_" + key, vmax)) st->max_exp_avg_sq(vmax.clone());
      opt.state()[adam_state_key(param)] = std::move(st);
    }
  if (count.toInt() != k)
    throw Error(path.string() + ": optimizer state for " + std::to_string(count.toInt()) + " parameters, the network has " +
                std::to_string(k) + "; start a new run");
}

}  // namespace

void save_checkpoint(const fs::path& path, Pix2Pix& p, const TrainParams& params, int64_t step,
                     const LogWindow& window, int world_size) {
  torch::serialize::OutputArchive a;
  a.write("format", c10::IValue(std::string(kCheckpointFormat)));
  a.write("format_version", c10::IValue(kCheckpointVersion));
  a.write("reefgen_version", c10::IValue(std::string(kVersion)));
  a.write("config", c10::IValue(json(params).dump()));
  a.write("step", c10::IValue(step));
  const torch::Tensor log_window = torch::tensor(
      {window.sums[0], window.sums[1], window.sums[2], window.sums[3], double(window.steps)}, torch::kFloat64);
  const torch::Tensor rng = at::detail::getDefaultCPUGenerator().get_state();
  a.write("log_window", log_window);
  a.write("torch_rng", rng);
  a.write("sha256", c10::IValue(checkpoint_sha256(p, step, log_window, rng)));
  // Results depend on the thread count (reductions split differently).
  a.write("torch_threads", c10::IValue(int64_t(torch::get_num_threads())));
  a.write("world_size", c10::IValue(int64_t(world_size)));  // config's batch_size is per rank
  torch::serialize::OutputArchive g, d, og, od;
  p.G()->save(g);
  p.D()->save(d);
  save_adam(p.opt_G(), og);
  save_adam(p.opt_D(), od);
  a.write("G", g);
  a.write("D", d);
  a.write("opt_G", og);
  a.write("opt_D", od);
  try {
    model::save_archive_atomic(a, path);
  } catch (const std::exception& e) {
    throw Error(e.what());
  }
}

// Opens a checkpoint archive and returns the config it was written with;
// `fix` ends every error message.
static TrainParams open_checkpoint(torch::serialize::InputArchive& a, const fs::path& path, const std::string& fix) {
  try {
    model::load_archive(a, path, "checkpoint", fix);
    model::expect_format(a, path, kCheckpointFormat, kCheckpointVersion, "a checkpoint written by `reefgen train`");
  } catch (const std::runtime_error& e) {
    throw Error(e.what());
  }
  json stored;
  try {
    stored = parse_json_checked(model::read_string(a, "config"), path.string() + " (its config)");
  } catch (const json::exception&) {
    throw Error(path.string() + ": unreadable config; " + fix);
  }
  return train_params_from_json(stored, path.string());
}

int64_t load_checkpoint(const fs::path& path, Pix2Pix& p, const TrainParams& params, LogWindow* window,
                        int64_t* torch_threads, int world_size, int64_t* world_size_then) {
  torch::serialize::InputArchive a;
  const std::string fix = "start a new run (another --out) or restore the file";
  const TrainParams stored = open_checkpoint(a, path, fix);
  c10::IValue ws;
  const int64_t world_then = a.try_read("world_size", ws) ? ws.toInt() : 1;  // older checkpoints: one process
  if (world_size_then) *world_size_then = world_then;
  const json want = comparable_config(params, world_size);
  const json have = comparable_config(stored, world_then);
  for (const auto& [k, v] : want.items())
    if (have.at(k) != v) {
      if (k == "global_batch")
        throw Error(path.string() + ": the run was started with a global batch of " + have.at(k).dump() + " (" +
                    std::to_string(stored.batch_size) + " per rank x " + std::to_string(world_then) + " ranks), now " +
                    v.dump() + " (" + std::to_string(params.batch_size) + " x " + std::to_string(world_size) +
                    "); pass --batch-size so that batch size x ranks = " + have.at(k).dump());
      throw Error(path.string() + ": the run was started with " + k + " = " + have.at(k).dump() + ", now " +
                  v.dump() + "; resume with the run's config (RUN/run.json) or start a new run");
    }
  try {
    c10::IValue v;
    a.read("step", v);
    const int64_t step = v.toInt();
    torch::Tensor w, rng;
    a.read("log_window", w);
    a.read("torch_rng", rng);
    torch::serialize::InputArchive g, d, og, od;
    a.read("G", g);
    a.read("D", d);
    a.read("opt_G", og);
    a.read("opt_D", od);
    p.G()->load(g);
    p.D()->load(d);
    load_adam(p.opt_G(), og, path);
    load_adam(p.opt_D(), od, path);
    at::Generator gen = at::detail::getDefaultCPUGenerator();
    gen.set_state(rng);
    if (window) {
      auto acc = w.accessor<double, 1>();
      for (int k = 0; k < 4; ++k) window->sums[k] = acc[k];
      window->steps = int64_t(acc[4]);
    }
    if (torch_threads) {
      a.read("torch_threads", v);
      *torch_threads = v.toInt();
    }
    // Checkpoints written before the checksum existed load without it.
    if (a.try_read("sha256", v) && v.isString() && v.toStringRef() != checkpoint_sha256(p, step, w, rng))
      throw Error(path.string() + ": the checkpoint's SHA-256 does not match its contents (corrupted copy); " + fix);
    return step;
  } catch (const c10::Error& e) {
    throw Error(path.string() + ": damaged checkpoint (" + model::first_line(e.what_without_backtrace()) + "); " + fix);
  }
}

bool same_architecture(const TrainParams& a, const TrainParams& b, std::string* differing) {
  const json ja = a, jb = b;
  for (const char* k : {"ngf", "ndf", "depth", "d_layers", "norm", "upsample", "maturity_channel"})
    if (ja.at(k) != jb.at(k)) {
      if (differing) *differing = std::string(k) + " = " + ja.at(k).dump() + " there, " + jb.at(k).dump() + " here";
      return false;
    }
  return true;
}

namespace {

// A convolution's weight {out,in,k,k} that reads more input channels here
// than in the file, and is otherwise the same.
bool widened_input(const torch::Tensor& file, const torch::Tensor& here) {
  if (file.dim() != 4 || here.dim() != 4 || here.size(1) <= file.size(1)) return false;
  for (int64_t d : {0, 2, 3})
    if (file.size(d) != here.size(d)) return false;
  return true;
}

// Copies every tensor of `from` into the same-named tensor of `to`; throws
// when a name or shape differs (another architecture). With widen, a weight
// that reads more input channels here (G's first convolution with the
// maturity channel added) takes the file's channels first and zeros for the
// new ones: the widened G answers every input as the file's G did.
void copy_tensors(const torch::OrderedDict<std::string, torch::Tensor>& from,
                  torch::OrderedDict<std::string, torch::Tensor>& to, const fs::path& path, bool widen = false) {
  if (from.size() != to.size())
    throw Error(path.string() + ": another architecture (" + std::to_string(from.size()) + " tensors, this config has " +
                std::to_string(to.size()) + "); start from a generator of the same networks or change the config");
  torch::NoGradGuard no_grad;
  for (const auto& item : from) {
    torch::Tensor* t = to.find(item.key());
    if (t && widen && widened_input(item.value(), *t)) {
      t->zero_();
      t->narrow(1, 0, item.value().size(1)).copy_(item.value());
      continue;
    }
    if (!t || !t->sizes().equals(item.value().sizes()))
      throw Error(path.string() + ": another architecture (tensor " + item.key() +
                  "); start from a generator of the same networks or change the config");
    t->copy_(item.value());
  }
}

// An exported generator (RUN/generator.pt, models/reef-256.pt) starts G from
// its weights and D afresh: fine-tuning the shipped model on new targets.
// False when the file is not a generator file.
bool load_generator_weights(const fs::path& path, Pix2Pix& p) {
  model::GeneratorFile f;
  try {
    f = model::load_generator(path);
  } catch (const std::exception&) {
    return false;
  }
  auto params = p.G()->named_parameters();
  auto buffers = p.G()->named_buffers();
  copy_tensors(f.g->named_parameters(), params, path, /*widen=*/true);
  copy_tensors(f.g->named_buffers(), buffers, path);
  return true;
}

}  // namespace

void load_checkpoint_weights(const fs::path& path, Pix2Pix& p, const TrainParams& params) {
  if (!fs::is_regular_file(path))
    throw Error(path.string() + ": no such checkpoint to start from (--init takes another run's RUN/checkpoint.pt "
                "or an exported generator)");
  if (load_generator_weights(path, p)) return;
  torch::serialize::InputArchive a;
  const std::string fix = "pass --init another run's RUN/checkpoint.pt";
  std::string differing;
  if (!same_architecture(open_checkpoint(a, path, fix), params, &differing))
    throw Error(path.string() + ": another architecture (" + differing +
                "); start from a checkpoint of the same networks or change the config to match");
  try {
    torch::serialize::InputArchive g, d;
    a.read("G", g);
    a.read("D", d);
    p.G()->load(g);
    p.D()->load(d);
  } catch (const c10::Error& e) {
    throw Error(path.string() + ": damaged checkpoint (" + model::first_line(e.what_without_backtrace()) + "); " + fix);
  }
}

}  // namespace reefgen::train
