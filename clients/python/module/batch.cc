#include "clients/python/module/batch.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>

#include "clients/python/module/inputs.h"

namespace coopdyn::py {

namespace pyb = pybind11;

namespace {

struct Stacks {
  pyb::array_t<double> q, v, tau;
  long n = -1;
};

Stacks read_stacks(const Scene& s, pyb::handle Q, pyb::handle V, pyb::handle TAU) {
  const SceneNames& nm = *s.names();
  const System& sys = s.sys();
  Stacks st;
  for (pyb::handle h : {Q, V, TAU})
    if (st.n < 0 && !h.is_none()) {
      const pyb::object a = pyb::module_::import("numpy").attr("asarray")(h);
      if (pyb::len(a.attr("shape")) >= 1) st.n = a.attr("shape").cast<pyb::tuple>()[0].cast<long>();
    }
  if (st.n < 0) throw pyb::value_error("evaluate_batch: give at least one of Q, V, TAU (N rows)");
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sys.model.nv());
  st.q = read_stack(Q, "Q", nm.q, "q_names", sys.q0, &st.n);
  st.v = read_stack(V, "V", nm.v, "v_names", sys.v0, &st.n);
  st.tau = read_stack(TAU, "TAU", nm.v, "v_names", zero, &st.n);
  return st;
}

std::int64_t* progress_slot(pyb::handle progress) {
  if (progress.is_none()) return nullptr;
  if (!pyb::array_t<std::int64_t>::check_(progress))
    throw pyb::value_error("progress: expected a writable numpy int64 array (np.zeros(1, dtype=np.int64))");
  auto a = pyb::reinterpret_borrow<pyb::array_t<std::int64_t>>(progress);
  if (a.size() < 1 || !a.writeable()) throw pyb::value_error("progress: expected a writable int64 array of size >= 1");
  return a.mutable_data();
}

pyb::array strings(const std::vector<const char*>& table, const pyb::array_t<std::int8_t>& codes) {
  pyb::list words;
  for (const char* w : table) words.append(pyb::str(w));
  return pyb::module_::import("numpy").attr("array")(words).attr("__getitem__")(codes);
}

}  // namespace

pyb::dict evaluate_batch(const Scene& s, pyb::handle Q, pyb::handle V, pyb::handle TAU, pyb::handle progress) {
  const System& sys = s.sys();
  const SceneNames& nm = *s.names();
  const Stacks in = read_stacks(s, Q, V, TAU);
  std::int64_t* done = progress_slot(progress);
  const long N = in.n;
  const int nq = sys.model.nq(), nv = sys.model.nv(), nw = static_cast<int>(nm.wrench.size());
  const int ns = static_cast<int>(nm.stress.size());
  const bool sig = WrenchSigmaData(sys).declared;
  pyb::array_t<double> vdot({N, static_cast<long>(nv)}), stress({N, static_cast<long>(ns)});
  pyb::array_t<double> cond(N), resid(N);
  pyb::array_t<std::int32_t> rank(N);
  pyb::array_t<std::int8_t> status(N), reason(N);
  // every wrench of a state side by side (one contiguous write per state), then one view per name
  pyb::array_t<double> W({N, static_cast<long>(nw), 6L}), S({sig ? N : 0L, static_cast<long>(nw), 6L});
  double *Wp = W.mutable_data(), *Sp = S.mutable_data();
  const double *qp = in.q.data(), *vp = in.v.data(), *tp = in.tau.data();
  double *vd = vdot.mutable_data(), *st = stress.mutable_data(), *cp = cond.mutable_data(), *rp = resid.mutable_data();
  std::int32_t* rk = rank.mutable_data();
  std::int8_t *stp = status.mutable_data(), *rsp = reason.mutable_data();
  {
    pyb::gil_scoped_release nogil;
    EvalBuffers b(sys);
    Eigen::VectorXd q(nq), v(nv), tau(nv);
    for (long r = 0; r < N; ++r) {
      q = Eigen::Map<const Eigen::VectorXd>(qp + r * nq, nq);
      v = Eigen::Map<const Eigen::VectorXd>(vp + r * nv, nv);
      tau = Eigen::Map<const Eigen::VectorXd>(tp + r * nv, nv);
      const Diagnostics& d = evaluate_into(sys, b, q, v, tau);
      Eigen::Map<Eigen::VectorXd>(vd + r * nv, nv) = b.ws.vdot;
      for (int k = 0; k < nw; ++k) {
        Eigen::Map<Vec6>(Wp + (r * nw + k) * 6) = b.wd.W[k];
        if (sig) Eigen::Map<Vec6>(Sp + (r * nw + k) * 6) = b.sd.valid ? b.sd.sigma[k] : Vec6::Constant(std::nan(""));
      }
      if (ns) Eigen::Map<Eigen::VectorXd>(st + r * ns, ns) = b.ws.stress;
      cp[r] = d.condition, rp[r] = d.residual, rk[r] = d.rank;
      stp[r] = static_cast<std::int8_t>(d.status), rsp[r] = static_cast<std::int8_t>(d.reason);
      if (done) __atomic_store_n(done, static_cast<std::int64_t>(r + 1), __ATOMIC_RELEASE);
    }
  }
  pyb::dict out, wrenches, sigma;
  const pyb::object all = pyb::slice(pyb::none(), pyb::none(), pyb::none());
  for (int k = 0; k < nw; ++k) {
    wrenches[pyb::str(nm.wrench[k])] = W[pyb::make_tuple(all, k, all)];
    if (sig) sigma[pyb::str(nm.wrench[k])] = S[pyb::make_tuple(all, k, all)];
  }
  std::vector<const char*> status_words, reason_words;
  for (int c = 0; c < 3; ++c) status_words.push_back(status_name(static_cast<Status>(c)));
  for (int c = 0; c < 128; ++c) reason_words.push_back(reason_key(static_cast<Reason>(c)));
  out["vdot"] = vdot;
  out["wrenches"] = wrenches;
  out["wrench_stack"] = W;
  out["sigma"] = sigma;
  out["stresses"] = stress;
  out["status"] = strings(status_words, status);
  out["reason"] = strings(reason_words, reason);
  out["rank"] = rank;
  out["condition"] = cond;
  out["residual"] = resid;
  return out;
}

double time_evaluate(const Scene& s, pyb::handle Q, pyb::handle V, pyb::handle TAU, int repeat) {
  const System& sys = s.sys();
  const Stacks in = read_stacks(s, Q, V, TAU);
  const int nq = sys.model.nq(), nv = sys.model.nv();
  pyb::gil_scoped_release nogil;
  EvalBuffers b(sys);
  Eigen::VectorXd q(nq), v(nv), tau(nv);
  double sink = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < repeat; ++k)
    for (long r = 0; r < in.n; ++r) {
      q = Eigen::Map<const Eigen::VectorXd>(in.q.data() + r * nq, nq);
      v = Eigen::Map<const Eigen::VectorXd>(in.v.data() + r * nv, nv);
      tau = Eigen::Map<const Eigen::VectorXd>(in.tau.data() + r * nv, nv);
      sink += evaluate_into(sys, b, q, v, tau).residual;
    }
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sink == -1 ? 0 : dt / (static_cast<double>(repeat) * static_cast<double>(in.n));
}

}  // namespace coopdyn::py
