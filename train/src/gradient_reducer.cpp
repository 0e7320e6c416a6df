// Gradients averaged over the ranks while backward runs: bucketed
// all-reduces launched from gradient-accumulator hooks.
#include <algorithm>
#include <cstring>

#include <torch/csrc/autograd/utils/lambda_post_hook.h>

#include "dist_internal.hpp"

namespace reefgen::train {

struct GradientReducer::State {
  Comm& comm;
  std::vector<torch::Tensor> params;
  std::string what;
  int64_t cap;  // floats per bucket
  // The accumulators must live as long as the hooks: a parameter keeps only
  // a weak reference to its own.
  std::vector<std::shared_ptr<torch::autograd::Node>> accumulators;
  std::vector<uintptr_t> hook_keys;
  bool armed = false;
  std::vector<int64_t> observed;            // first step: ready order on this rank
  std::vector<std::vector<size_t>> buckets;  // parameter indices, in launch order
  std::vector<int> bucket_of;                // parameter -> bucket
  std::vector<int> missing;                  // per bucket: gradients not in yet
  size_t next = 0;                           // next bucket to launch
  struct InFlight {
    size_t bucket;
    torch::Tensor flat;
    c10::intrusive_ptr<c10d::Work> work;
  };
  std::vector<InFlight> in_flight;
  State(Comm& c, std::vector<torch::Tensor> p, std::string w, int64_t k)
      : comm(c), params(std::move(p)), what(std::move(w)), cap(k) {}

  void launch(size_t b) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<torch::Tensor> views;
    for (size_t i : buckets[b]) {
      const torch::Tensor& g = params[i].grad();
      views.push_back(g.defined() ? g.reshape({-1}) : torch::zeros({params[i].numel()}, params[i].options()));
    }
    // A gradient as large as a bucket travels in place (no packing and
    // unpacking passes over it); smaller ones are packed together.
    const torch::Tensor& g0 = params[buckets[b][0]].grad();
    const bool in_place = buckets[b].size() == 1 && g0.defined() && g0.is_contiguous();
    InFlight f{b, in_place ? g0.view({-1}) : torch::cat(views), {}};  // {bucket floats}
    std::vector<at::Tensor> one = {f.flat};
    f.work = comm.impl_->pg->allreduce(one);
    in_flight.push_back(std::move(f));
    comm.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  void ready(size_t i) {
    if (!armed) return;
    if (buckets.empty()) {
      observed.push_back(int64_t(i));
      return;
    }
    const int b = bucket_of[i];
    if (b < 0 || --missing[size_t(b)] > 0) return;
    while (next < buckets.size() && missing[next] <= 0) launch(next++);
  }
  void plan(const std::vector<int64_t>& order) {
    bucket_of.assign(params.size(), -1);
    int64_t n = 0;
    for (int64_t i : order) {
      if (i < 0) continue;
      if (buckets.empty() || n + params[size_t(i)].numel() > cap) {
        buckets.emplace_back();
        n = 0;
      }
      buckets.back().push_back(size_t(i));
      bucket_of[size_t(i)] = int(buckets.size() - 1);
      n += params[size_t(i)].numel();
    }
  }
};

GradientReducer::GradientReducer(Comm& comm, std::vector<torch::Tensor> params, std::string what, double bucket_mb)
    : s_(std::make_unique<State>(comm, std::move(params), std::move(what),
                                 std::max<int64_t>(1, int64_t(bucket_mb * 1e6 / 4)))) {
  State* st = s_.get();
  for (size_t i = 0; i < st->params.size(); ++i) {
    auto acc = torch::autograd::impl::grad_accumulator(st->params[i]);
    st->hook_keys.push_back(acc->add_post_hook(std::make_unique<torch::autograd::utils::LambdaPostHook>(
        [st, i](const torch::autograd::variable_list& outputs, const torch::autograd::variable_list&) {
          st->ready(i);  // the gradient is in params[i].grad() now
          return outputs;
        })));
    st->accumulators.push_back(std::move(acc));
  }
}

GradientReducer::~GradientReducer() {
  for (size_t i = 0; i < s_->accumulators.size(); ++i) s_->accumulators[i]->del_post_hook(s_->hook_keys[i]);
}

void GradientReducer::begin() {
  State& st = *s_;
  st.armed = true;
  st.next = 0;
  st.in_flight.clear();
  st.missing.assign(st.buckets.size(), 0);
  for (size_t b = 0; b < st.buckets.size(); ++b) st.missing[b] = int(st.buckets[b].size());
}

void GradientReducer::end() {
  State& st = *s_;
  Comm& comm = st.comm;
  st.armed = false;
  if (comm.world_size() == 1) return;
  try {
    if (st.buckets.empty()) {  // the first step: adopt rank 0's ready order
      torch::Tensor order = torch::full({int64_t(st.params.size())}, int64_t(-1), torch::kInt64);
      for (size_t k = 0; k < st.observed.size() && k < st.params.size(); ++k) order[int64_t(k)] = st.observed[k];
      std::vector<at::Tensor> one = {order};
      c10d::BroadcastOptions o;
      comm.impl_->pg->broadcast(one, o)->wait();
      std::vector<int64_t> v(order.data_ptr<int64_t>(), order.data_ptr<int64_t>() + order.numel());
      // Parameters that got no gradient on rank 0 still travel, last.
      std::vector<bool> seen(st.params.size(), false);
      for (int64_t i : v)
        if (i >= 0) seen[size_t(i)] = true;
      for (size_t i = 0; i < st.params.size(); ++i)
        if (!seen[i]) v.push_back(int64_t(i));
      st.plan(v);
      st.observed.clear();
      st.next = 0;
      st.missing.assign(st.buckets.size(), 0);
    }
    while (st.next < st.buckets.size()) st.launch(st.next++);  // what backward did not complete
    const auto t0 = std::chrono::steady_clock::now();
    const double inv = 1.0 / double(comm.world_size());
    for (auto& f : st.in_flight) {
      f.work->wait();
      f.flat.mul_(inv);
      const torch::Tensor& g0 = st.params[st.buckets[f.bucket][0]].grad();
      if (g0.defined() && g0.data_ptr() == f.flat.data_ptr()) continue;  // reduced in place
      int64_t off = 0;
      for (size_t i : st.buckets[f.bucket]) {
        torch::Tensor& p = st.params[i];
        const int64_t n = p.numel();
        if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
        p.mutable_grad().copy_(f.flat.narrow(0, off, n).view_as(p));
        off += n;
      }
    }
    st.in_flight.clear();
    comm.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    st.in_flight.clear();
    comm.fail(st.what, e);
  }
}

}  // namespace reefgen::train
