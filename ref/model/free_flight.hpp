#pragma once
// Exact free flight (docs/orbits.md). Between contacts Eq. 1 (and the linear effects of the rig)
// is linear with harmonic forcing,
//   s' = A s + b + Re sum_h F_h e^{i h w t},
// so from (t0, s0) the flow is, with A = V Lambda V^-1,
//   s(t) = p(t) + Re V e^{Lambda (t - t0)} V^-1 (s0 - p(t0)),
//   p(t) = -A^-1 b + Re sum_h (i h w - A)^-1 F_h e^{i h w t}       (the periodic particular solution)
// A free arc then costs a few dozen flops per evaluation whatever its length, and its state
// transition matrix e^{A (t - t0)} = Re V e^{Lambda (t - t0)} V^-1 is exact (the monodromy's free
// factors).
//
// Contact onset, the first t with z(t) = l.s(t) - offset > 0, is found by guaranteed safe steps:
// from a point a with z(a) < 0, |z''| <= M on [a, a + H] (M from the modal amplitudes, below)
// gives z(a + tau) <= z(a) + z'(a) tau + M tau^2 / 2, which stays <= 0 up to the root tau* of that
// parabola. The march from a to a + tau* never steps over a crossing; near a crossing the steps
// shrink like Newton steps from below. A step is never shorter than sqrt(2 d / M), so an episode
// shallower than d may be passed over, and no deeper one can be: d is the `min_depth` (1e-12 of
// the clearance by default) or z's own rounding (arc::rounding), whichever is larger. The crossing
// found is bracketed by TOMS 748 on the exact z from the last point seen outside.

#include <Eigen/Dense>
#include <array>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "ref/base/errors.hpp"
#include "ref/model/state.hpp"

namespace rubref {

// How many ulps of its terms' sizes a sum of them is known to (free_flight::arc::rounding): the
// few roundings of each term's own evaluation, with a wide margin.
inline constexpr double kRoundingUlps = 64.0;

// What a System says its free flight is (`free_dynamics()`): s' = A s + b + Re sum_h F_h e^{i h w t},
// and the penetration z = normal . s - offset whose first zero ends the arc.
template <int N>
struct linear_dynamics {
  static constexpr int kMaxHarmonics = 2;  // the unbalance (and bow) at 1X, misalignment at 2X
  using matrix = Eigen::Matrix<double, N, N>;
  using vector = Eigen::Matrix<double, N, 1>;
  using complex_vector = Eigen::Matrix<std::complex<double>, N, 1>;

  matrix A = matrix::Zero();
  vector b = vector::Zero();
  std::array<complex_vector, kMaxHarmonics> F{complex_vector::Zero(), complex_vector::Zero()};  // orders 1 and 2
  double omega = 0.0;                                                                               // rad/s, signed
  vector normal = vector::Zero();
  double offset = 0.0;  // m
};

// The flow of a linear_dynamics. Components whose row of A, b and F is zero (a rigid stator's) are
// constants of the flow and kept out of the eigenproblem.
template <int N>
class free_flight {
 public:
  using state = std::array<double, N>;
  using dynamics = linear_dynamics<N>;
  using cscalar = std::complex<double>;

 private:
  using sub_matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, N, N>;
  using sub_vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>;
  using sub_cmatrix = Eigen::Matrix<cscalar, Eigen::Dynamic, Eigen::Dynamic, 0, N, N>;
  using sub_cvector = Eigen::Matrix<cscalar, Eigen::Dynamic, 1, 0, N, 1>;
  struct eigenbasis {
    sub_matrix a;  // the moving components' A
    sub_cvector lambda;
    sub_cmatrix V, Vinv;
  };

 public:

  // The eigendecomposition and the particular solution (defined after the class, compiled once for
  // N = 4 and 6 in ref/model/free_flight.cpp).
  explicit free_flight(const dynamics& d);

  // e^a for a modal exponent a = lambda tau: the real part's exponential turned by the forcing's
  // fast phasor (ref/model/state.hpp), within a few ulps of std::exp and without its complex
  // special cases (a is finite here).
  static cscalar exp_of(cscalar a) noexcept {
    const forcing_phasor u = phasor_of(a.imag());
    const double r = std::exp(a.real());
    return {r * u.cos, r * u.sin};
  }

  // The particular (periodic) solution at t.
  state particular(double t) const {
    const forcing_phasor u = phasor_of(d_.omega * t);
    const cscalar z1(u.cos, u.sin), z2 = z1 * z1;
    state p{};
    for (int i = 0; i < N; ++i) p[static_cast<std::size_t>(i)] = p0_[i] + (P_[0][i] * z1).real() + (P_[1][i] * z2).real();
    return p;
  }

  // One free arc from (t0, s0).
  class arc {
   public:
    arc(const free_flight& ff, double t0, const state& s0) : ff_(&ff), t0_(t0), s0_(s0) {
      const state p = ff.particular(t0);
      c_.resize(ff.n_);
      for (int j = 0; j < ff.n_; ++j) {
        cscalar s = 0.0;
        for (int r = 0; r < ff.n_; ++r) {
          const auto i = static_cast<std::size_t>(ff.active_[static_cast<std::size_t>(r)]);
          s += ff.Vinv_(j, r) * (s0[i] - p[i]);
        }
        c_[j] = s;
      }
      q_.resize(ff.n_);
      lc_.resize(ff.n_);
      for (int j = 0; j < ff.n_; ++j) {
        q_[j] = std::abs(ff.lV_[j]) * std::norm(ff.lambda_[j]) * std::abs(c_[j]);
        lc_[j] = ff.weight_[j] * ff.lV_[j] * c_[j];
      }
      // The modes' shares of the state (at()): w_rj = weight_j V_rj c_j, split in real and
      // imaginary parts; a pair's second mode (weight 0) is left out.
      for (int j = 0; j < ff.n_; ++j) {
        if (ff.weight_[j] == 0.0) continue;
        const auto k = static_cast<std::size_t>(modes_++);
        for (int q = 0; q < ff.n_; ++q) {
          const cscalar w = ff.weight_[j] * (ff.V_(q, j) * c_[j]);
          w_re_[k][static_cast<std::size_t>(q)] = w.real();
          w_im_[k][static_cast<std::size_t>(q)] = w.imag();
        }
      }
      z_const_ = ff.lp0_ - ff.d_.offset;
      for (int i = 0; i < N; ++i)
        if (!ff.is_active(i)) z_const_ += ff.d_.normal[i] * s0[static_cast<std::size_t>(i)];
    }

    double start_time() const noexcept { return t0_; }

    // What a state is made of at one time: the forcing's phasor e^{i w t} and each mode's
    // e^{lambda_j (t - t0)} (at() and walk).
    struct phasors {
      std::complex<double> forcing;
      std::array<std::complex<double>, N> mode{};
    };

    // The state at t, in real arithmetic: the particular solution's harmonics from their cached
    // real and imaginary parts, then each mode's e^{lambda_j tau} (a conjugate pair's once, its
    // share twice the real part) times the arc's w_rj = weight_j V_rj c_j. Sampling every record
    // sample of every dwell is most of a loop fit's time (docs/orbits.md).
    state at(double t) const {
      phasors ph;
      exact_phasors(t, ph);
      return from_phasors(ph);
    }

    // The states at t, t + dt, t + 2 dt, ... (a uniform grid, as records and the loop's harmonic
    // band are sampled): the forcing's phasor and each mode's e^{lambda_j tau} are turned by their
    // fixed step (one complex multiply each) instead of evaluated anew (an exponential and a
    // phasor each), and taken exactly again every kExactEvery points, so rounding cannot build
    // up: it stays within ~kExactEvery ulps of each term (benchmarks walk_free_arc and
    // sample_free_arc in bench/contact_bench.cpp time both).
    class walk {
     public:
      // `step`: the free flight's step_phasors(dt) for the grid's spacing dt.
      walk(const arc& a, const phasors& step) : arc_(&a), step_(&step) {}
      // The state at the next grid point, t (the previous one's t + dt; every kExactEvery-th,
      // the first included, is at(t) itself).
      state next(double t) {
        if (taken_ % kExactEvery == 0) {
          arc_->exact_phasors(t, now_);
        } else {
          now_.forcing *= step_->forcing;
          for (int k = 0; k < arc_->modes_; ++k) now_.mode[static_cast<std::size_t>(k)] *= step_->mode[static_cast<std::size_t>(k)];
        }
        ++taken_;
        return arc_->from_phasors(now_);
      }

     private:
      static constexpr std::size_t kExactEvery = 32;
      const arc* arc_;
      const phasors* step_;
      std::size_t taken_ = 0;
      phasors now_;
    };
    walk walk_by(const phasors& step) const { return walk(*this, step); }

    // z and z' at t (z = normal . s - offset), from the projections of the solution on the
    // normal alone: z = l.p0 - offset + Re sum_h (l.P_h) e^{i h w t} + Re sum_j (l.V_j) c_j e^{lambda_j tau}.
    std::pair<double, double> penetration(double t) const { return evaluate(t, nullptr); }

    // How well z(t) and z'(t) are known: kRoundingUlps ulps of the sum of their terms' sizes.
    // Near the stator z is a difference of terms much larger than itself (4 mm of forcing
    // response against a 5.7 um clearance near resonance), and every phase (w t, Im(lambda) tau)
    // is rounded to an ulp of itself, which moves a term by its size times that ulp: the
    // rounding grows with |w t|.
    std::pair<double, double> rounding(double t) const {
      std::pair<double, double> r;
      evaluate(t, &r);
      return r;
    }

    // A bound on |z''| over [ta, tb] (ta >= t0): the modal terms' largest size there plus the
    // forcing's, widened by a margin for rounding.
    double curvature_bound(double ta, double tb) const {
      double m = ff_->particular_bound_;
      for (int j = 0; j < ff_->n_; ++j) {
        const double re = ff_->lambda_[j].real();
        m += q_[j] * std::exp(re * ((re > 0.0 ? tb : ta) - t0_));
      }
      return m * (1.0 + 1e-9) + std::numeric_limits<double>::min();
    }

    // The first contact onset in (from, t_end]: a bracket [outside, inside] of width <= time_tol
    // around the first zero of z reached by an episode deeper than min_depth and than z's own
    // rounding, or none. z(from) may be positive to rounding only on the boundary the arc starts
    // from (after an event).
    std::optional<std::pair<double, double>> first_onset(double from, double t_end, double min_depth, double time_tol,
                                                         double window, std::size_t* marching_steps = nullptr) const {
      constexpr std::size_t kMaxSteps = 10'000'000;  // a bound that always holds makes steps of at least sqrt(2 d / M)
      double a = from;
      std::pair<double, double> noise;
      auto [za, zda] = evaluate(a, &noise);
      // Below its rounding, z > 0 is not a contact (after a release on y = delta the rotor would
      // otherwise "touch" again at once, and after an impact it would be hit again at the same instant).
      const double depth = std::max(min_depth, noise.first);
      if (za > depth) return std::pair{from, from};
      // The crossing is bracketed from the last point seen outside (z <= 0): from a point with
      // 0 < z < noise it would be located late and inside, at the higher speed found there.
      double t_out = a, z_out = std::min(za, 0.0);
      za = z_out;
      for (std::size_t k = 0; a < t_end; ++k) {
        if (k == kMaxSteps) throw numerical_error("free flight: the onset search does not advance");
        if (marching_steps) ++*marching_steps;
        const double b_max = std::min(t_end, a + window);
        const double M = curvature_bound(a, b_max);
        if (!std::isfinite(za) || !std::isfinite(zda) || !std::isfinite(M))
          throw numerical_error("free flight: a non-finite state at t = " + std::to_string(a) + " s (a growing mode)");
        // Largest tau with za + zda tau + M tau^2 / 2 <= 0 (za <= 0), in a cancellation-free form.
        const double disc = std::sqrt(zda * zda - 2.0 * M * za);
        double tau = zda > 0.0 ? -2.0 * za / (zda + disc) : (disc - zda) / M;
        tau = std::max(tau, std::sqrt(2.0 * depth / M));
        if (!(tau > 0.0)) throw numerical_error("free flight: the onset search lost its step at t = " + std::to_string(a) + " s");
        const double b = std::min(a + tau, b_max);
        const auto [zb, zdb] = evaluate(b, &noise);
        if (zb > std::max(min_depth, noise.first)) {
          const auto f = [this](double t) { return penetration(t).first; };
          return bracket(f, t_out, b, z_out, zb, time_tol);
        }
        if (zb <= 0.0) {
          t_out = b;
          z_out = zb;
        }
        a = b;
        za = std::min(zb, 0.0);  // (a rounding-level z > 0 is on the boundary)
        zda = zdb;
      }
      return std::nullopt;
    }

   private:
    // z and z' at t; with `round`, also their rounding (see rounding()).
    std::pair<double, double> evaluate(double t, std::pair<double, double>* round) const {
      const double w = ff_->d_.omega;
      const forcing_phasor u = phasor_of(w * t);
      const cscalar z1(u.cos, u.sin), z2 = z1 * z1;
      const cscalar p1 = ff_->lP_[0] * z1, p2 = ff_->lP_[1] * z2;
      double z = z_const_ + p1.real() + p2.real();
      double zd = -w * (p1.imag() + 2.0 * p2.imag());  // d/dt Re(a e^{i w t}) = -w Im(a e^{i w t})
      const double tau = t - t0_;
      double size_z = 0.0, size_zd = 0.0;
      if (round) {
        const double a1 = std::abs(ff_->lP_[0]), a2 = std::abs(ff_->lP_[1]);
        const double phase = 1.0 + std::abs(w * t);  // the forcing phase's rounding, in ulps of a term
        size_z = std::abs(z_const_) + std::abs(ff_->lp0_) + std::abs(ff_->d_.offset) + (a1 + 2.0 * a2) * phase;
        size_zd = std::abs(w) * (a1 + 4.0 * a2) * phase;
      }
      for (int j = 0; j < ff_->n_; ++j) {
        if (ff_->weight_[j] == 0.0) continue;  // the conjugate of the term before
        const cscalar m = exp_of(ff_->lambda_[j] * tau) * lc_[j];
        z += m.real();
        zd += (ff_->lambda_[j] * m).real();
        if (round) {
          const double phase = 1.0 + std::abs(ff_->lambda_[j] * tau);
          size_z += std::abs(m) * phase;
          size_zd += std::abs(ff_->lambda_[j]) * std::abs(m) * phase;
        }
      }
      if (round) {
        constexpr double ulp = std::numeric_limits<double>::epsilon();
        *round = {kRoundingUlps * ulp * size_z, kRoundingUlps * ulp * size_zd};
      }
      return {z, zd};
    }

    template <class F>
    static std::pair<double, double> bracket(F&& f, double a, double b, double fa, double fb, double tol) {
      std::uintmax_t iterations = 200;
      const auto done = [tol](double lo, double hi) {
        return hi - lo <= std::max(tol, 4.0 * std::numeric_limits<double>::epsilon() * std::abs(hi));
      };
      // The contact phase must start strictly inside (z > 0): a rounded z of exactly 0 counts as
      // outside, so TOMS 748 never stops on an exact zero and the inner end always has z > 0.
      const auto g = [&f](double t) {
        const double z = f(t);
        return z == 0.0 ? -std::numeric_limits<double>::denorm_min() : z;
      };
      auto r = boost::math::tools::toms748_solve(g, a, b, fa < 0.0 ? fa : -std::numeric_limits<double>::denorm_min(), fb, done,
                                                    iterations);
      if (!(f(r.second) > 0.0)) throw numerical_error("free flight: the onset bracket lost its inner end");
      return r;
    }

    void exact_phasors(double t, phasors& ph) const {
      const free_flight& ff = *ff_;
      const forcing_phasor u = phasor_of(ff.d_.omega * t);
      ph.forcing = {u.cos, u.sin};
      const double tau = t - t0_;
      for (int k = 0; k < modes_; ++k) {
        const auto j = static_cast<std::size_t>(ff.mode_[static_cast<std::size_t>(k)]);
        const forcing_phasor e = phasor_of(ff.lambda_im_[j] * tau);
        const double r = std::exp(ff.lambda_re_[j] * tau);
        ph.mode[static_cast<std::size_t>(k)] = {r * e.cos, r * e.sin};
      }
    }
    state from_phasors(const phasors& ph) const {
      const free_flight& ff = *ff_;
      const double uc = ph.forcing.real(), us = ph.forcing.imag();
      const double c2 = uc * uc - us * us, s2 = 2.0 * uc * us;  // the 2X phasor
      state s;
      for (std::size_t i = 0; i < N; ++i)
        s[i] = ff.constant_[i] ? s0_[i]
                               : ff.p0_[static_cast<Eigen::Index>(i)] + (ff.p_re_[0][i] * uc - ff.p_im_[0][i] * us) +
                                     (ff.p_re_[1][i] * c2 - ff.p_im_[1][i] * s2);
      for (int k = 0; k < modes_; ++k) {
        const double er = ph.mode[static_cast<std::size_t>(k)].real(), ei = ph.mode[static_cast<std::size_t>(k)].imag();
        const auto& wr = w_re_[static_cast<std::size_t>(k)];
        const auto& wi = w_im_[static_cast<std::size_t>(k)];
        for (int q = 0; q < ff.n_; ++q) {
          const auto row = static_cast<std::size_t>(q);
          s[static_cast<std::size_t>(ff.active_[row])] += wr[row] * er - wi[row] * ei;
        }
      }
      return s;
    }

    const free_flight* ff_;
    double t0_;
    state s0_;
    sub_cvector c_;               // modal coordinates of s0 - p(t0)
    sub_cvector lc_;              // weight_j (l.V_j) c_j: each mode's share of z
    double z_const_ = 0.0;        // l.p0 - offset + the constant components' share of z
    Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> q_;  // |l.V_j| |lambda_j|^2 |c_j|
    int modes_ = 0;                                        // modes with a share (weight != 0), in ff.mode_'s order
    std::array<std::array<double, N>, N> w_re_{}, w_im_{};  // [mode][active row]: weight_j V_rj c_j
  };

  arc from(double t0, const state& s0) const { return arc(*this, t0, s0); }

  // One step dt of a uniform grid as arc::walk turns by it: e^{i w dt} and each mode's
  // e^{lambda_j dt}, in the arcs' mode order (computed once per integration, not per arc).
  typename arc::phasors step_phasors(double dt) const {
    typename arc::phasors step;
    const forcing_phasor u = phasor_of(d_.omega * dt);
    step.forcing = {u.cos, u.sin};
    int k = 0;
    for (int j = 0; j < n_; ++j) {
      if (weight_[j] == 0.0) continue;
      const forcing_phasor e = phasor_of(lambda_im_[static_cast<std::size_t>(j)] * dt);
      const double r = std::exp(lambda_re_[static_cast<std::size_t>(j)] * dt);
      step.mode[static_cast<std::size_t>(k++)] = {r * e.cos, r * e.sin};
    }
    return step;
  }

  // e^{A tau}: the state transition matrix of a free arc of length tau (exact; identity rows for
  // the constant components).
  Eigen::Matrix<double, N, N> transition(double tau) const {
    Eigen::Matrix<double, N, N> phi = Eigen::Matrix<double, N, N>::Identity();
    sub_cmatrix e = V_;
    for (int j = 0; j < n_; ++j) e.col(j) *= std::exp(lambda_[j] * tau);
    const sub_cmatrix m = e * Vinv_;
    for (int r = 0; r < n_; ++r)
      for (int c = 0; c < n_; ++c)
        phi(active_[static_cast<std::size_t>(r)], active_[static_cast<std::size_t>(c)]) = m(r, c).real();
    return phi;
  }

  const dynamics& model() const noexcept { return d_; }

 private:
  // max |v_i| (a plain loop: GCC 12 misreads Eigen's vectorised reduction over a vector of
  // dynamic size with a fixed maximum as out of bounds).
  template <class Vec>
  static double largest(const Vec& v) {
    double m = 0.0;
    for (Eigen::Index i = 0; i < v.size(); ++i) m = std::max(m, std::abs(v[i]));
    return m;
  }

  bool is_active(int i) const noexcept {
    for (int k = 0; k < n_; ++k)
      if (active_[static_cast<std::size_t>(k)] == i) return true;
    return false;
  }

  dynamics d_;
  int n_ = 0;
  std::array<int, N> active_{};
  sub_cvector lambda_;
  sub_cmatrix V_, Vinv_;
  typename dynamics::vector p0_;
  std::array<typename dynamics::complex_vector, dynamics::kMaxHarmonics> P_;
  sub_cvector lV_;
  std::array<cscalar, dynamics::kMaxHarmonics> lP_{};  // l.P_h
  double lp0_ = 0.0;                                    // l.p0
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1> weight_;  // 2: a pair's first mode, 0: its second, 1: a real mode
  double particular_bound_ = 0.0;
  // What arc::at reads, in real form: the components the flow leaves constant, the harmonics'
  // parts P_h = p_re + i p_im, and the modes with a share (weight != 0) with their eigenvalues.
  std::array<bool, N> constant_{};
  std::array<std::array<double, N>, dynamics::kMaxHarmonics> p_re_{}, p_im_{};
  std::array<int, N> mode_{};
  std::array<double, N> lambda_re_{}, lambda_im_{};
};

template <int N>
free_flight<N>::free_flight(const dynamics& d) : d_(d) {
  for (int i = 0; i < N; ++i) {
    bool moves = d.b[i] != 0.0;
    for (int j = 0; j < N && !moves; ++j) moves = d.A(i, j) != 0.0;
    for (const auto& f : d.F) moves = moves || f[i] != 0.0;
    if (moves) active_[static_cast<std::size_t>(n_++)] = i;
  }
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < n_; ++k)
      if (!is_active(i) && d.A(active_[static_cast<std::size_t>(k)], i) != 0.0)
        throw numerical_error("free flight: a moving component depends on a constant one");
  sub_matrix a(n_, n_);
  for (int r = 0; r < n_; ++r)
    for (int c = 0; c < n_; ++c) a(r, c) = d.A(active_[static_cast<std::size_t>(r)], active_[static_cast<std::size_t>(c)]);
  // The eigenbasis depends on A alone, which a continuation in speed, unbalance or mu and the
  // flows of one shooting share: the last one is kept per thread (a pure function of A's bits,
  // compared as bits so that even a zero's sign matches, so the results are the same bits with
  // or without it, on any number of threads).
  thread_local std::optional<eigenbasis> last;
  const auto same_bits = [&](const sub_matrix& m) {
    return m.rows() == n_ && std::memcmp(m.data(), a.data(), sizeof(double) * static_cast<std::size_t>(n_ * n_)) == 0;
  };
  if (!(last && same_bits(last->a))) {
    last.reset();
    eigenbasis e;
    e.a = a;
    Eigen::EigenSolver<sub_matrix> eig(a);
    if (eig.info() != Eigen::Success) throw numerical_error("free flight: no eigendecomposition of the linear dynamics");
    e.lambda = eig.eigenvalues();
    e.V = eig.eigenvectors();
    const Eigen::PartialPivLU<sub_cmatrix> lu(e.V);
    e.Vinv = lu.inverse();
    // A defective (or nearly so) A, e.g. exactly critical damping, has no usable eigenbasis.
    const double cond = e.V.cwiseAbs().colwise().sum().maxCoeff() * e.Vinv.cwiseAbs().colwise().sum().maxCoeff();
    if (!(cond < 1e8)) throw numerical_error("free flight: the linear dynamics have no well-conditioned eigenbasis");
    last = std::move(e);
  }
  lambda_ = last->lambda;
  V_ = last->V;
  Vinv_ = last->Vinv;
  // The particular solution: constant and harmonic parts.
  p0_ = dynamics::vector::Zero();
  sub_vector bs(n_);
  for (int r = 0; r < n_; ++r) bs[r] = d.b[active_[static_cast<std::size_t>(r)]];
  if (largest(bs) > 0.0) {
    const sub_vector p = a.fullPivLu().solve(-bs);
    if (!(a * p + bs).isZero(1e-9 * bs.norm())) throw numerical_error("free flight: no static equilibrium of the linear dynamics");
    for (int r = 0; r < n_; ++r) p0_[active_[static_cast<std::size_t>(r)]] = p[r];
  }
  for (int h = 0; h < dynamics::kMaxHarmonics; ++h) {
    P_[static_cast<std::size_t>(h)] = dynamics::complex_vector::Zero();
    sub_cvector f(n_);
    for (int r = 0; r < n_; ++r) f[r] = d.F[static_cast<std::size_t>(h)][active_[static_cast<std::size_t>(r)]];
    if (largest(f) == 0.0) continue;
    const sub_cmatrix m = cscalar(0.0, (h + 1) * d.omega) * sub_cmatrix::Identity(n_, n_) - a.template cast<cscalar>();
    const Eigen::PartialPivLU<sub_cmatrix> mlu(m);
    const sub_cvector p = mlu.solve(f);
    if (!p.allFinite() || !(largest(sub_cvector(m * p - f)) <= 1e-9 * largest(f)))
      throw numerical_error("free flight: the forcing is at an undamped resonance");
    for (int r = 0; r < n_; ++r) P_[static_cast<std::size_t>(h)][active_[static_cast<std::size_t>(r)]] = p[r];
  }
  // What the onset search reads: l.V_j, l.P_h.
  lV_.resize(n_);
  for (int j = 0; j < n_; ++j) {
    cscalar s = 0.0;
    for (int r = 0; r < n_; ++r) s += d.normal[active_[static_cast<std::size_t>(r)]] * V_(r, j);
    lV_[j] = s;
  }
  particular_bound_ = 0.0;
  for (int h = 0; h < dynamics::kMaxHarmonics; ++h) {
    const double w = (h + 1) * d.omega;
    lP_[static_cast<std::size_t>(h)] = d.normal.template cast<cscalar>().dot(P_[static_cast<std::size_t>(h)]);
    particular_bound_ += std::abs(lP_[static_cast<std::size_t>(h)]) * w * w;
  }
  lp0_ = d.normal.dot(p0_);
  // A real A's complex eigenvalues come in conjugate pairs with conjugate eigenvectors (Eigen
  // builds them so, exactly), and a real state has conjugate modal coordinates on them: the
  // pair's share of z is twice the real part of one term, which halves the onset search's
  // complex exponentials.
  weight_.resize(n_);
  for (int j = 0; j < n_; ++j) weight_[j] = 1.0;
  for (int j = 0; j + 1 < n_; ++j)
    if (weight_[j] == 1.0 && lambda_[j].imag() != 0.0 && lambda_[j + 1] == std::conj(lambda_[j]) &&
        V_.col(j + 1) == V_.col(j).conjugate()) {
      weight_[j] = 2.0;
      weight_[j + 1] = 0.0;
    }
  for (int i = 0; i < N; ++i) {
    const auto c = static_cast<std::size_t>(i);
    constant_[c] = !is_active(i);
    for (std::size_t h = 0; h < P_.size(); ++h) {
      p_re_[h][c] = P_[h][i].real();
      p_im_[h][c] = P_[h][i].imag();
    }
  }
  for (int j = 0, k = 0; j < n_; ++j)
    if (weight_[j] != 0.0) mode_[static_cast<std::size_t>(k++)] = j;
  for (int j = 0; j < n_; ++j) {
    lambda_re_[static_cast<std::size_t>(j)] = lambda_[j].real();
    lambda_im_[static_cast<std::size_t>(j)] = lambda_[j].imag();
  }
}

// The two flows the library has (the rotor, and the rotor with a stator of its own mass), compiled
// once: their eigendecompositions were a large part of every file that made a free flight.
extern template class free_flight<4>;
extern template class free_flight<6>;

}  // namespace rubref
