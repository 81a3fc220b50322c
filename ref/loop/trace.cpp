#include "ref/loop/trace.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "ref/format/record.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/loop/paper_fit.hpp"
#include "ref/loop/residuals.hpp"
#include "ref/loop/search.hpp"
#include "ref/orbits/fit_orbits.hpp"

namespace rubref {

namespace {

// Relative finite-difference step of an effect's linearised regressors (as the fit's Jacobian).
constexpr double kStep = 1e-3;
// A candidate is refitted only if its linearised score reaches this share of the best one's:
// a far weaker linear signal rarely overtakes after the refit, and each refit costs a fit.
constexpr double kRefitScoreShare = 0.1;
// How often a fair comparison may hand the round over to a better base fit (each costs a refit
// and a rescoring); after that a candidate that fails it is only rejected.
constexpr int kMaxBaseRestarts = 3;
// Jacobians of each out-of-sample fit: they start from the fits on every dwell, a few steps away.
constexpr int kHoldoutIterations = 6;
// A refit among the best few that removes this share of the synchronous excess leaves the others
// at most the tenth that is left to gain, so they are not refitted (the best few always are:
// near twins such as a contact angle and turned probes both reach it, and only their refits
// tell them apart). (The loop claims effects only where they remove more: evidence_rules::claim_share.)
constexpr double kSettledShare = 0.9;
// Jacobians of a screening refit (try_refit): enough for a refit that will pass to show a gain.
constexpr int kScreenIterations = 5;
// Jacobians each start of a refit is fitted before the one then lowest takes the rest of the
// budget (race_starts). One Jacobian carries up to three Broyden steps: enough for a start on the
// right base to pass one whose base was bent to absorb the effect. A screening refit's budget
// (kScreenIterations) races up to four starts and leaves the leader the rest; with five or more
// starts (a profiled effect's) it fits the lowest start alone.
constexpr int kRaceLap = 1;
// How often a fit is carried on from its end on the data's orbits (on_the_datas_orbits).
constexpr int kOrbitRefits = 2;

// What every step of a round reads.
struct round_context {
  const std::vector<loop_dwell>& dwells;
  orbit_predictor& predictor;
  double noise;
  double rows;  // orbit residuals (N of the BIC)
  const model_point& staged;
  const trace_settings& s;
};

// A model of the trace: its point, its coordinates, its residual and the orbits it is on.
struct fitted_model {
  model_point at;
  std::vector<fit_coordinate> coords;
  Eigen::VectorXd r;
  orbit_anchors orbits;
  double uncertainty = 0.0;  // m^2: rss()'s numerical uncertainty (rss_uncertainty)
  double rss() const { return r.squaredNorm(); }
};

// The numerical uncertainty of a model's |r|^2 (m^2), which every statistic of the evidence rules
// inherits (ref/inference/evidence.hpp): the fit's unfinished descent (`remaining`: how much lower
// its minimum may lie), and its orbits' error per sample (fit_orbit_options::orbit_error).
double rss_uncertainty(const Eigen::VectorXd& r, double remaining, const fit_orbit_options& orbits) {
  return cost_uncertainty(r, remaining, orbits.orbit_error());
}

// A model on its orbits: those found from the data, or those its fit followed (`f`) where they
// fit better. Where orbits coexist, the data's motion is the model's orbit nearest to it, and a
// fit that followed one must not be judged on another (a refit that can only lower the residual
// would come out worse than its start).
std::optional<fitted_model> judge(const round_context& c, const model_point& m, std::vector<fit_coordinate> coords,
                                  const fit_result* f = nullptr) {
  auto r = residual_at(c.predictor, m);
  orbit_anchors orbits = c.predictor.last_orbits();
  if (f && f->ok && f->r.size() > 0 && (!r || f->r.squaredNorm() < r->squaredNorm())) {
    r = f->r;
    orbits = f->orbits;
  }
  if (!r) return std::nullopt;
  const double u = rss_uncertainty(*r, f && f->ok ? f->remaining : 0.0, c.predictor.orbit_options());
  return fitted_model{m, std::move(coords), std::move(*r), std::move(orbits), u};
}

// A fit judged, and carried on from its end where the orbits found from the data fit that end
// better than those the fit followed: a fit follows its start's orbits, and from a far start (the
// Table 2 law's, where the fit had gone to k3 z^3) it can follow one of coexisting orbits the data
// is not on (1.35e-6 m^2 on a period-2 dwell's record, 3.8e-9 at the same point on the data's
// orbits; every later refit then gained only by finishing this fit).
std::optional<fitted_model> on_the_datas_orbits(const round_context& c, const fit_problem& problem, const fit_result& f) {
  if (!f.ok) return std::nullopt;
  auto judged = judge(c, f.at, problem.coords, &f);
  double followed = f.rss;
  for (int more = 0; judged && judged->rss() < followed && more < kOrbitRefits; ++more) {
    const fit_result g = fit(problem, problem.of(judged->at), c.s.max_jacobians, &judged->orbits);
    if (!g.ok) break;
    auto next = judge(c, g.at, problem.coords, &g);
    if (!next || !(next->rss() < judged->rss())) break;
    followed = g.rss;
    judged = std::move(next);
  }
  return judged;
}

// The significance rule (ref/inference/evidence.hpp) of `with` against `without`: a rise of the
// criterion without it, a share of the synchronous excess, and a change of the synchronous energy
// larger than the synchronous check's own tolerance. With 1e5-1e6 samples a criterion rise is
// reached by a change of the orbit of a few per cent of the noise (a cross-coupling of 1.5 N/m
// took 75 % of what a contact angle left); the check that calls a residual noise could not see
// such a change, and neither can the claim.
struct significance {
  part_comparison comparison;  // criterion rise (the BIC drop), excess share, synchronous energy removed against the check's tolerance
  need judged;
  double bic_drop() const { return comparison.criterion_rise; }
  double excess_share() const { return comparison.excess_share; }
  bool pass() const { return judged.significant; }
};
double criterion_of(const round_context& c, const fitted_model& m) { return information_criterion(m.rss(), c.rows, m.coords.size()); }
significance test(const round_context& c, const fitted_model& without, const fitted_model& with) {
  significance out;
  part_comparison& pc = out.comparison;
  pc.criterion_rise = criterion_of(c, without) - criterion_of(c, with);
  pc.criterion_rise_uncertainty = criterion_change_uncertainty(c.rows, without.rss(), without.uncertainty, with.rss(), with.uncertainty);
  const synchronous_energy base = synchronous_part(c.dwells, c.predictor, without.at, without.r, c.s.orders);
  const double after = synchronous_part(c.dwells, c.predictor, with.at, with.r, c.s.orders).energy;
  const double excess = base.excess(c.noise);
  pc.excess_share = excess > 0.0 ? (base.energy - after) / excess : 0.0;
  pc.change = base.energy - after;
  pc.resolution = base.tolerance(c.noise);
  // The synchronous energy is a part of |r|^2: a model that may move |r|^2 by u moves it by at most as much.
  pc.change_uncertainty = without.uncertainty + with.uncertainty;
  pc.excess_share_uncertainty = excess > 0.0 ? pc.change_uncertainty / excess : 0.0;
  out.judged = judge_need(pc, c.s.rules);
  return out;
}

// How strong an effect is at m, in units of the weakest level the library documents for it (its
// largest switch): below the evidence rules' min_documented_level (a tenth) the library calls it
// invisible, and a fit that puts it
// there is using it to absorb something else (a contact angle of 0.0006 rad next to an
// unexplained Hertz law).
double documented_strength(const effect_info& e, const model_point& m) {
  double strength = 0.0;
  for (const auto& f : e.fit)
    for (const auto& q : e.parameters) {
      if (q.key != f.key || f.is_shape()) continue;
      const double v = m.fx.*q.member;
      switch (f.form) {
        case fit_form::value:
        case fit_form::polar:
          strength = std::max(strength, std::abs(v) / q.level_lo);
          break;
        case fit_form::compliance:  // the stiffest documented stator is the weakest effect
          strength = std::max(strength, v > 0.0 ? q.level_hi / v : 0.0);
          break;
        case fit_form::excess_over_mu:
          strength = std::max(strength, v > m.p.mu ? (v - m.p.mu) / std::max(q.level_lo - m.p.mu, 1e-3) : 0.0);
          break;
        case fit_form::power_coefficient:  // the levels hold at the reference penetration (ref/model/effects.hpp)
          for (const auto& c : effect_coordinates(e))
            if (c.name.ends_with("@z_ref")) strength = std::max(strength, c.get(m) / q.level_lo);
          break;
        default:
          break;
      }
    }
  return strength;
}

std::vector<fit_coordinate> without_effect(const std::vector<fit_coordinate>& coords, std::string_view effect) {
  std::vector<fit_coordinate> out;
  for (const auto& q : coords)
    if (q.effect != effect) out.push_back(q);
  return out;
}

// The effect off: its switches at 0 (its shapes stay where they are: they act on nothing then).
model_point switched_off(model_point m, const effect_info& e) {
  for (const auto& q : effect_coordinates(e))
    if (!q.shape) q.set(m, 0.0);
  return m;
}

// The base problem linearised at the staged model's base (the current effects kept): where the
// before-fit bent the linear part to absorb a missing effect (a combined record's few
// contact-free dwells leave it free to), a Gauss-Newton step taken there, not at the bent fit,
// points to the effect's model on the right base.
struct staged_linearisation {
  model_point at;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;  // base coordinates, shifts last (as the base problem's u)
};

// A candidate's scores and the starts its refit may take.
struct scored {
  effect_candidate candidate;
  const effect_info* effect = nullptr;
  Eigen::VectorXd gauss_newton;         // the step of (base, effect) coordinates, shifts last
  Eigen::VectorXd staged_step;          // the same at the staged model's base (staged_linearisation)
  std::optional<model_point> trial_at;  // its profile's best value on the current point
  std::optional<Eigen::VectorXd> trial_corrected;  // the same with the base's linear correction (base problem's u)
};

// The effect's switch columns at m (residual r0 there in harmonics, the predictor anchored at m):
// nothing where the model cannot be computed with the effect switched on a little.
std::optional<Eigen::MatrixXd> switch_columns(const round_context& c, const model_point& m0, const Eigen::VectorXd& r0,
                                              const std::vector<fit_coordinate>& ec) {
  const std::size_t switches = switch_count(ec);
  Eigen::MatrixXd S(r0.size(), static_cast<Eigen::Index>(switches));
  for (std::size_t j = 0; j < switches; ++j) {
    model_point m = m0;
    ec[j].set(m, kStep * ec[j].scale);
    const auto r = c.predictor.harmonic_residuals(m);
    if (!r) return std::nullopt;
    S.col(static_cast<Eigen::Index>(j)) = (*r - r0) / kStep;
  }
  return S;
}

Eigen::VectorXd gauss_newton_step(const Eigen::MatrixXd& J, const Eigen::MatrixXd& S, const Eigen::VectorXd& r0) {
  Eigen::MatrixXd JS(J.rows(), J.cols() + S.cols());
  JS << J, S;
  return -JS.colPivHouseholderQr().solve(r0);
}

// Scores every remaining effect at `current`: the error reduction ratio of its linearised
// regressors on the residual, after what the base coordinates' Jacobian already spans; for an
// effect with trial values also its profile's share, if higher. Best first. With `staged`, each
// effect's Gauss-Newton step there too (the predictor is anchored at current.at when it returns).
// Residuals, columns and J are in harmonics (orbit_predictor::harmonic_residuals, r0 at current):
// the samples' ratios, with the data's part outside the band in every denominator.
std::vector<scored> score(const round_context& c, const fitted_model& current, const std::vector<const effect_info*>& remaining,
                          const fit_problem& base, const Eigen::VectorXd& r0, const Eigen::MatrixXd& J,
                          const std::optional<staged_linearisation>& staged) {
  const double outside = c.predictor.harmonic_offset();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qj(J);
  const Eigen::MatrixXd Qj = qj.householderQ() * Eigen::MatrixXd::Identity(J.rows(), qj.rank());
  const auto project_out = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd { return v - Qj * (Qj.transpose() * v); };
  const double P0 = project_out(r0).squaredNorm() + outside;
  std::vector<scored> out;
  for (const auto* e : remaining) {
    scored sc;
    sc.effect = e;
    sc.candidate.name = std::string(e->name);
    // Its switches' columns: a shape's derivative where the effect is off is 0.
    const auto ec = effect_coordinates(*e);
    const auto S = switch_columns(c, current.at, r0, ec);
    if (!S) {  // the model cannot be computed with the effect switched on a little
      sc.candidate.verdict = "its model cannot be computed next to the current one";
      out.push_back(std::move(sc));
      continue;
    }
    sc.candidate.score = err_score(J, *S, r0, outside);
    sc.gauss_newton = gauss_newton_step(J, *S, r0);
    // An effect with trial values (it enters nonlinearly) is also scored by its profile: the
    // residual left, after the base coordinates' linear correction, with the effect at a value.
    // Its share of the base's residual is the linear score's analogue; the best value, base
    // corrected, is a start of its refit.
    for (const auto& q : ec) {
      if (!q.trials) continue;
      const auto left = [&](double value) {
        model_point m = current.at;
        q.trials->apply(m, value);
        const auto r = c.predictor.harmonic_residuals(m);
        return r ? project_out(*r).squaredNorm() + outside : std::numeric_limits<double>::infinity();
      };
      const profile_best best = profile(q.trials->values, P0, left);
      const double share = P0 > 0.0 ? 1.0 - best.left / P0 : 0.0;
      if (!(share > sc.candidate.score)) continue;
      sc.candidate.score = share;
      model_point m = current.at;
      q.trials->apply(m, best.value);
      if (const auto r = c.predictor.harmonic_residuals(m)) {
        sc.trial_at = m;
        sc.trial_corrected = base.of(m) - qj.solve(*r);
      }
    }
    out.push_back(std::move(sc));
  }
  if (staged) {
    c.predictor.anchor(staged->at);
    for (auto& sc : out)
      if (sc.candidate.verdict.empty())
        if (const auto S = switch_columns(c, staged->at, staged->r, effect_coordinates(*sc.effect)))
          sc.staged_step = gauss_newton_step(staged->J, *S, staged->r);
    c.predictor.anchor(current.at, current.orbits);
  }
  std::stable_sort(out.begin(), out.end(), [](const scored& a, const scored& b) { return a.candidate.score > b.candidate.score; });
  return out;
}

// The refit of a candidate with every coordinate: from the best of its starts (the effect off;
// its Gauss-Newton point; the same on the staged model's base; its profile's best value as it
// is, base-corrected, and on the staged model), or by its coordinate's dip search.
std::optional<fitted_model> refit(const round_context& c, const fitted_model& current, const scored& sc, std::string& start_name) {
  auto with = current.coords;
  const auto ec = effect_coordinates(*sc.effect);
  with.insert(with.end(), ec.begin(), ec.end());
  const fit_problem problem = make_problem(c.predictor, c.dwells, current.at, with, c.noise);
  if (const auto searched = dip_searched(ec); searched != ec.end()) {
    start_name = "dip search";
    const auto j = current.coords.size() + static_cast<std::size_t>(searched - ec.begin());
    const bool paper_only = std::all_of(current.coords.begin(), current.coords.end(), [](const fit_coordinate& q) { return q.effect.empty(); });
    const fit_result f = search_dips(problem, j, current.rss(), paper_only ? c.staged : current.at, c.dwells, c.s.max_jacobians, c.s.progress);
    return f.ok ? judge(c, f.at, with, &f) : std::nullopt;
  }
  const auto nb = static_cast<Eigen::Index>(current.coords.size()), ne = static_cast<Eigen::Index>(ec.size());
  const auto ns = static_cast<Eigen::Index>(switch_count(ec));
  const Eigen::VectorXd off = problem.of(current.at);
  const auto shifts = off.size() - nb - ne;
  std::vector<named_start> starts{{"off", current.at, current.orbits}};
  if (sc.gauss_newton.size() == nb + ns + shifts) {
    // The step's columns are the base problem's (coordinates, shifts), then the effect's
    // switches; its shapes start from the library's typical values.
    Eigen::VectorXd gn = off;
    gn.head(nb) += sc.gauss_newton.head(nb);
    gn.segment(nb, ns) = sc.gauss_newton.tail(ns);
    gn.tail(shifts) += sc.gauss_newton.segment(nb, shifts);
    starts.push_back({"gauss-newton", problem.at(gn), current.orbits});
    // The same effect part on the staged model's base (the linear part from the dwells without
    // contact, the law from FROLS): a fit without the effect may have bent the base far from
    // where the effect's model fits (a before-fit without a preload bends the law to absorb it).
    model_point on_staged = current.at;
    on_staged.p = c.staged.p;
    const fit_problem staged_problem = make_problem(c.predictor, c.dwells, on_staged, with, c.noise);
    Eigen::VectorXd us = staged_problem.of(on_staged);
    us.segment(nb, ns) = sc.gauss_newton.tail(ns);
    starts.push_back({"staged + gauss-newton", staged_problem.at(us)});
    if (sc.staged_step.size() == nb + ns + shifts) {  // the step taken at the staged model's base
      Eigen::VectorXd at_staged = staged_problem.of(on_staged);
      at_staged.head(nb) += sc.staged_step.head(nb);
      at_staged.segment(nb, ns) = sc.staged_step.tail(ns);
      at_staged.tail(shifts) += sc.staged_step.segment(nb, shifts);
      starts.push_back({"gauss-newton at the staged model", staged_problem.at(at_staged)});
    }
  }
  if (sc.trial_at) {
    starts.push_back({"profile", *sc.trial_at});
    Eigen::VectorXd corrected = problem.of(*sc.trial_at);
    corrected.head(nb) = sc.trial_corrected->head(nb);
    corrected.tail(shifts) = sc.trial_corrected->tail(shifts);
    starts.push_back({"profile, base corrected", problem.at(corrected)});
    model_point staged = *sc.trial_at;
    staged.p = c.staged.p;
    for (const auto& q : ec) q.set(staged, q.get(*sc.trial_at));
    starts.push_back({"profile on the staged model", staged});
  }
  // One fit, from the start that leads after a lap (race_starts): a second one from another
  // start is the fair comparison's and the backward elimination's job, which test every addition
  // against the refitted base.
  const multistart_result m = race_starts(problem, starts, c.s.max_jacobians, kRaceLap);
  start_name = m.winner;
  return m.best.ok ? judge(c, m.best.at, with, &m.best) : std::nullopt;
}

// The effect's gain out of sample, in chi^2: the dwells in two folds (alternate dwells of each
// record in speed order, contact and free apart), the models with and without the effect refitted
// on one fold (from their fits on every dwell, and from those on the staged base) and compared on
// the other. Its numerical uncertainty: each fold fit's unfinished descent (a move that may still
// lower the fold's |r|^2 by R moves the other fold's, on the same orbits, by about as much), the
// held orbits' error (rss_uncertainty), and the spread of the two starts' predictions where they
// fit the fold alike. NaN where the model without the effect cannot predict a held fold (the
// test is not made), -inf where the model with it cannot.
statistic holdout_gain(const round_context& c, const fitted_model& without, const fitted_model& with) {
  std::vector<int> fold(c.dwells.size(), 0);
  std::map<std::pair<std::string, bool>, std::vector<std::size_t>> groups;
  for (std::size_t k = 0; k < c.dwells.size(); ++k) groups[{c.dwells[k].record, c.dwells[k].contact}].push_back(k);
  for (auto& [key, members] : groups) {
    std::stable_sort(members.begin(), members.end(), [&](std::size_t a, std::size_t b) { return c.dwells[a].data.rpm < c.dwells[b].data.rpm; });
    for (std::size_t i = 0; i < members.size(); ++i) fold[members[i]] = static_cast<int>(i % 2);
  }
  const auto subset = [&](const model_point& m, const std::vector<std::size_t>& idx) {
    model_point out = m;
    out.shift.clear();
    for (const std::size_t k : idx) out.shift.push_back(m.shift[k]);
    return out;
  };
  const auto orbits_of = [&](const orbit_anchors& o, const std::vector<std::size_t>& idx) {
    orbit_anchors out;
    for (const std::size_t k : idx) out.push_back(k < o.size() ? o[k] : std::nullopt);
    return out;
  };
  double gain = 0.0, uncertainty = 0.0;
  for (int f = 0; f < 2; ++f) {
    std::vector<std::size_t> train, held;
    for (std::size_t k = 0; k < c.dwells.size(); ++k) (fold[k] == f ? held : train).push_back(k);
    if (train.empty() || held.empty()) continue;
    std::vector<loop_dwell> train_dwells, held_dwells;
    for (const std::size_t k : train) train_dwells.push_back(c.dwells[k]);
    for (const std::size_t k : held) held_dwells.push_back(c.dwells[k]);
    orbit_predictor on_train(train_dwells, c.noise, c.predictor.orbit_options()), on_held(held_dwells, c.noise, c.predictor.orbit_options());
    double rss[2];
    for (int i = 0; i < 2; ++i) {
      const fitted_model& m = i == 0 ? without : with;
      const orbit_anchors train_orbits = orbits_of(m.orbits, train), held_orbits = orbits_of(m.orbits, held);
      // Each fold is fitted from two starts: the model's fit on every dwell, and the same on the
      // before-fit's start (the staged base). From one start alone, which of the fold's minima it
      // reached decided the test by the orbits' last digits (seed 7919 #24). The lower fit on
      // the fold is the one held out; where the two fit it alike (within their numerical
      // uncertainty) and predict the other fold apart, that spread is the test's uncertainty too.
      struct fold_fit {
        double train = std::numeric_limits<double>::infinity(), train_uncertainty = 0.0;
        double held = std::numeric_limits<double>::infinity(), held_uncertainty = 0.0;
      };
      const auto fit_fold = [&](const model_point& start, const orbit_anchors* from) {
        fold_fit out;
        const fit_problem problem = make_problem(on_train, train_dwells, start, m.coords, c.noise);
        const fit_result fitted = fit(problem, problem.of(start), kHoldoutIterations, from);
        if (fitted.ok) out.train = fitted.rss, out.train_uncertainty = rss_uncertainty(fitted.r, fitted.remaining, on_train.orbit_options());
        model_point predicted = fitted.ok ? fitted.at : start;
        predicted.shift = subset(m.at, held).shift;  // timing is the held dwells' own, from every dwell's fit
        on_held.anchor(predicted, held_orbits);
        if (const auto r = on_held.residuals(predicted)) {
          const auto orbit = r->head(static_cast<Eigen::Index>(on_held.orbit_rows()));
          out.held = orbit.squaredNorm();
          out.held_uncertainty = rss_uncertainty(orbit, fitted.ok ? fitted.remaining : 0.0, on_held.orbit_options());
        }
        return out;
      };
      const model_point start = subset(m.at, train);
      model_point staged_start = start;
      staged_start.p = c.staged.p;
      const fold_fit a = fit_fold(start, &train_orbits), b = fit_fold(staged_start, nullptr);
      const fold_fit& best = std::isfinite(b.held) && b.train < a.train ? b : a;
      rss[i] = best.held;
      uncertainty += best.held_uncertainty;
      if (std::isfinite(a.held) && std::isfinite(b.held) && std::abs(a.train - b.train) <= a.train_uncertainty + b.train_uncertainty)
        uncertainty += std::abs(a.held - b.held);
    }
    if (!std::isfinite(rss[1])) return {-std::numeric_limits<double>::infinity(), 0.0};  // the model with it cannot predict them
    // The model without it cannot predict them: no gain can be measured (a +inf gain would pass
    // the rule on a failure); the caller reports the test as not made.
    if (!std::isfinite(rss[0])) return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
    gain += rss[0] - rss[1];
  }
  return {gain / (c.noise * c.noise), uncertainty / (c.noise * c.noise)};
}

// The 95 % bound of one parameter's profile likelihood, in chi^2 (Venzon & Moolgavkar 1988).
constexpr double kProfileChi2 = 3.84;
// Jacobians of the refit at each profile value: it starts from its neighbour's, a step away.
constexpr int kProfileIterations = 4;

// chi^2/dof of a fit where it exceeds 1: a residual that is not noise widens every interval by it.
double chi2_scale(const round_context& c, const fitted_model& m) {
  const double dof = std::max(c.rows - static_cast<double>(m.coords.size()), 1.0);
  return std::max(1.0, m.rss() / (c.noise * c.noise * dof));
}

// The profile of shape coordinate j of `current`: at profile_points values across its physical
// range, walking outward from the estimate, every other coordinate refitted from the neighbour's
// fit. Where a value lands lower than the fit by more than the bound, the fit with every
// coordinate free from there is `lower` (the profile is also the shape's global search).
struct profile_run {
  parameter_profile profile;
  std::optional<fitted_model> lower;
};
profile_run profile_coordinate(const round_context& c, const fitted_model& current, std::size_t j) {
  const fit_coordinate& q = current.coords[j];
  profile_run out;
  parameter_profile& p = out.profile;
  p.coordinate = q.name;
  p.quantity = q.quantity;
  p.unit = q.unit;
  p.estimate = q.natural(q.get(current.at));
  p.range_lo = q.range_lo, p.range_hi = q.range_hi;
  const int n = std::max(c.s.profile_points, 2);
  std::vector<double> grid;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    grid.push_back(q.logarithmic ? q.range_lo * std::pow(q.range_hi / q.range_lo, t) : q.range_lo + t * (q.range_hi - q.range_lo));
  }
  auto others = current.coords;
  others.erase(others.begin() + static_cast<std::ptrdiff_t>(j));
  const double unit = c.noise * c.noise * chi2_scale(c, current);
  std::vector<double> rss(grid.size(), std::numeric_limits<double>::infinity());
  std::vector<std::optional<fitted_model>> fits(grid.size());
  const auto walk = [&](auto first, auto last, auto next) {
    const fitted_model* from = &current;
    for (auto i = first; i != last; i = next(i)) {
      model_point m = from->at;
      q.set(m, q.chart(grid[static_cast<std::size_t>(i)]));
      const fit_problem problem = make_problem(c.predictor, c.dwells, m, others, c.noise);
      const fit_result f = fit(problem, problem.of(m), kProfileIterations, &from->orbits);
      if (!f.ok) break;  // beyond a value the model cannot be computed at, the walk stops
      auto judged = judge(c, f.at, current.coords, &f);
      if (!judged) break;
      rss[static_cast<std::size_t>(i)] = judged->rss();
      fits[static_cast<std::size_t>(i)] = std::move(*judged);
      from = &*fits[static_cast<std::size_t>(i)];
    }
  };
  const auto split = static_cast<int>(std::lower_bound(grid.begin(), grid.end(), p.estimate) - grid.begin());
  walk(split - 1, -1, [](int i) { return i - 1; });
  walk(split, static_cast<int>(grid.size()), [](int i) { return i + 1; });
  p.interval_lo = p.range_lo, p.interval_hi = p.range_hi;
  std::size_t lowest = grid.size();
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double d = (rss[i] - current.rss()) / unit;
    p.values.push_back(grid[i]);
    p.delta_chi2.push_back(d);  // +inf: the model cannot be computed there (or beyond, on the walk)
    if (d > kProfileChi2) {
      if (grid[i] < p.estimate) p.bounded_below = true, p.interval_lo = grid[i];
      if (grid[i] > p.estimate && !p.bounded_above) p.bounded_above = true, p.interval_hi = grid[i];
    }
    if (d < -kProfileChi2 && (lowest == grid.size() || rss[i] < rss[lowest])) lowest = i;
  }
  const auto range = format_digits(p.range_lo) + " ... " + format_digits(p.range_hi) + " " + p.unit;
  p.verdict = p.bounded_below && p.bounded_above ? "determined"
              : p.bounded_below                  ? "bounded below only: the records do not bound it above within " + range
              : p.bounded_above                  ? "bounded above only: the records do not bound it below within " + range
                                                 : "not identifiable: its profile is flat over " + range + "; the claim does not depend on it";
  if (lowest < grid.size()) {  // a better minimum: every coordinate free from there
    const fitted_model& from = *fits[lowest];
    const fit_problem problem = make_problem(c.predictor, c.dwells, from.at, current.coords, c.noise);
    const fit_result f = fit(problem, problem.of(from.at), c.s.max_jacobians, &from.orbits);
    if (f.ok)
      if (auto judged = judge(c, f.at, current.coords, &f); judged && judged->rss() < from.rss()) out.lower = std::move(*judged);
    if (!out.lower) out.lower = from;
  }
  return out;
}

// The shape coordinates of `effect` in the model's coordinates (indices); without those a dip
// search finds (`searched`: a profile across a comb of dips says only that the comb pins it).
std::vector<std::size_t> shapes_of(const std::vector<fit_coordinate>& coords, std::string_view effect, bool searched) {
  std::vector<std::size_t> out;
  for (std::size_t j = 0; j < coords.size(); ++j)
    if (coords[j].shape && coords[j].effect == effect && (searched || !coords[j].search)) out.push_back(j);
  return out;
}

// Every shape of `effect` profiled in turn, the model moved wherever a profile lands lower (the
// shapes' global search); the profiles of the final model.
std::vector<parameter_profile> settle_shapes(const round_context& c, fitted_model& m, std::string_view effect, bool searched) {
  std::vector<parameter_profile> profiles;
  for (int pass = 0; pass < 2; ++pass) {  // a move changes the other shapes' profiles: once more after one
    profiles.clear();
    bool moved = false;
    for (const std::size_t j : shapes_of(m.coords, effect, searched)) {
      profile_run run = profile_coordinate(c, m, j);
      if (run.lower && run.lower->rss() < m.rss()) {
        c.s.progress("      " + m.coords[j].name + ": its profile lands lower at " + format_digits(m.coords[j].natural(m.coords[j].get(run.lower->at))) +
                     " (residual " + format_digits(run.lower->rss()) + " against " + format_digits(m.rss()) + " m^2)");
        m = std::move(*run.lower);
        moved = true;
        run = profile_coordinate(c, m, j);
      }
      profiles.push_back(std::move(run.profile));
    }
    if (!moved) break;
  }
  return profiles;
}

// ---------------------------------------------------------------------------------------------
// The trace's rounds, step by step (trace, below, is their sequence).

// What the rounds share: the model so far, the effects not yet in it, and the trace's result.
struct trace_run {
  const round_context& c;
  trace_result out;
  fitted_model current;
  std::vector<const effect_info*> remaining;
  int base_restarts = 0;
  bool polished = false;  // the current structure has been refitted from the staged start

  void note(const std::string& text) {
    out.notes.push_back("trace: " + text);
    c.s.progress("      " + text);
  }
  // A decision about `effect` lay within its statistics' numerical uncertainty of its threshold:
  // the verdict is tentative, and names the effect among the tentative ones either way.
  void on_the_margin(const std::string& effect, const std::string& why) {
    if (std::find(out.on_margin.begin(), out.on_margin.end(), effect) == out.on_margin.end()) out.on_margin.push_back(effect);
    note(effect + ": " + why);
  }
  // Whether m's residual passes the validity checks (the predictor left anchored at m).
  bool is_noise(const fitted_model& m) const {
    c.predictor.anchor(m.at, m.orbits);  // the states its validity checks read
    const auto r = c.predictor.residuals(m.at);
    return r && validity(c.dwells, c.predictor, m.at, *r, c.noise, c.s.orders, c.s.whiteness_lags).pass;
  }
};

// After an effect is added, the model is refitted once from the before-fit's starts too (the
// staged model's base, and its linear part with the Table 2 law), raced, with the current effects:
// a base can fall into a degenerate minimum of its own (a law whose k1 went to 0 and k3 took its
// place while the effect was missing) that every later refit starts from. True when it moved. Not
// from the weak form's own law (the before-fit's third start): that law is such a minimum on the
// records whose FROLS law puts k3 z^3 in k1 z's place, and raced here it led the test record of
// that case (loop_test, a_misalignment_on_a_base_law_the_staged_start_gets_wrong) into it.
bool polish_from_the_staged_start(trace_run& run) {
  const round_context& c = run.c;
  std::vector<named_start> starts;
  for (named_start st : before_fit_starts(c.staged, std::nullopt)) {
    const parameters p = st.at.p;
    st.at = run.current.at;
    st.at.p = p;
    starts.push_back(std::move(st));
  }
  const fit_problem problem = make_problem(c.predictor, c.dwells, run.current.at, run.current.coords, c.noise);
  const multistart_result raced = race_starts(problem, starts, c.s.max_jacobians, kRaceLap);
  auto judged = on_the_datas_orbits(c, problem, raced.best);
  if (!judged || !(judged->rss() < run.current.rss())) return false;
  run.note("the model refitted from the before-fit's start '" + raced.winner + "' with its effects lands lower (residual " + format_digits(judged->rss()) +
           " against " + format_digits(run.current.rss()) + " m^2): it is the base from here");
  run.current = std::move(*judged);
  return true;
}

// Every remaining effect scored at the current model (linearised there and at the staged base).
std::vector<scored> score_round(trace_run& run) {
  const round_context& c = run.c;
  const fitted_model& current = run.current;
  const fit_problem base = make_problem(c.predictor, c.dwells, current.at, current.coords, c.noise);
  // Linearised in harmonics (what the fits search on), at the current model's own orbits.
  c.predictor.anchor(current.at, current.orbits);
  const auto r0 = c.predictor.harmonic_residuals(current.at);
  if (!r0) {  // its band's grid cannot be read where the record's phases could: nothing to linearise
    run.note("the current model cannot be linearised in harmonics: no effect is scored this round");
    return {};
  }
  const Eigen::MatrixXd J = base.harmonic_jacobian(base.of(current.at), *r0);
  std::optional<staged_linearisation> at_staged;
  model_point on_staged = current.at;
  on_staged.p = c.staged.p;
  c.predictor.anchor(on_staged);
  if (auto r = c.predictor.harmonic_residuals(on_staged)) {
    const fit_problem staged_problem = make_problem(c.predictor, c.dwells, on_staged, current.coords, c.noise);
    Eigen::MatrixXd Js = staged_problem.harmonic_jacobian(staged_problem.of(on_staged), *r);
    at_staged = staged_linearisation{on_staged, std::move(*r), std::move(Js)};
  }
  c.predictor.anchor(current.at, current.orbits);
  return score(c, current, run.remaining, base, *r0, J, at_staged);
}

// The refits of a round: candidates with their refit, significant against the current model.
struct round_refits {
  std::vector<std::pair<std::size_t, fitted_model>> passing;
  bool noise_left = false;      // a passing refit leaves only noise: the round is settled
  bool most_explained = false;  // one removes most of the excess (kSettledShare)
};

// The refit of candidate i, judged against the current model. A screened refit (one of the
// others, beyond the best few by score) is fitted a few Jacobians first, and the rest of its
// budget only where that already removes a third of the share of the synchronous excess the rule
// asks for (with 1e5 samples nearly every refit gains a criterion rise of 10): most of them gain
// nothing, and a fit that creeps along a valley for its whole budget was most of a last round's cost.
void try_refit(trace_run& run, std::vector<scored>& cands, std::size_t i, bool screen, round_refits& round) {
  const round_context& c = run.c;
  const fitted_model& current = run.current;
  trace_settings screening = c.s;
  screening.max_jacobians = std::min(c.s.max_jacobians, kScreenIterations);
  const round_context screened{c.dwells, c.predictor, c.noise, c.rows, c.staged, screening};
  auto& cand = cands[i].candidate;
  auto fitted = refit(screen ? screened : c, current, cands[i], cand.start);
  cand.refitted = true;
  if (!fitted) {
    cand.verdict = "its refit cannot be computed";
    return;
  }
  significance sig = test(c, current, *fitted);
  const auto record = [&] {
    cand.bic_drop = sig.bic_drop();
    cand.excess_share = sig.excess_share();
    cand.error_after = errors_of(c.dwells, c.predictor, fitted->r).nrmse_contact;
  };
  if (screen) {
    // Screened out only where the share falls short beyond its numerical uncertainty: one on the
    // margin is fitted on, and its full refit then meets the rules like any other.
    const decision gains = reaches({sig.excess_share(), sig.comparison.excess_share_uncertainty}, c.s.rules.min_excess_share / 3.0);
    if (!gains.yes && !gains.on_margin) {
      record();
      cand.verdict = "fails the significance rule (screened: " + std::to_string(kScreenIterations) + " Jacobians of its refit gain nothing)";
      return;
    }
    const fit_problem full = make_problem(c.predictor, c.dwells, fitted->at, fitted->coords, c.noise);
    const fit_result f = fit(full, full.of(fitted->at), c.s.max_jacobians, &fitted->orbits);
    if (f.ok)
      if (auto judged = judge(c, f.at, fitted->coords, &f); judged && judged->rss() < fitted->rss()) fitted = std::move(judged);
    sig = test(c, current, *fitted);
  }
  record();
  c.s.progress("      " + cand.name + " refitted (from '" + cand.start + "'): BIC drop " + format_digits(sig.bic_drop()) + ", share " +
               format_digits(sig.excess_share()) + ", error " + format_digits(cand.error_after));
  if (!sig.pass()) {
    cand.verdict = sig.judged.reason;
    if (sig.judged.on_margin) run.on_the_margin(cand.name, sig.judged.reason);
    return;
  }
  if (const double strength = documented_strength(*cands[i].effect, fitted->at); strength < c.s.rules.min_documented_level) {
    cand.verdict = "its fitted level is " + format_digits(strength, 2) + " of the weakest it documents: not an effect of this size";
    return;
  }
  if (const auto* q = outside_fit_range(*cands[i].effect, fitted->at)) {
    cand.verdict = "its fitted " + std::string(q->key) + " = " + format_digits(fitted->at.fx.*q->member) + " " + std::string(q->unit) +
                   " is outside the library's range [" + format_digits(q->lo) + ", " + format_digits(q->hi) + "]";
    return;
  }
  round.noise_left = round.noise_left || run.is_noise(*fitted);
  round.most_explained = round.most_explained || sig.excess_share() >= kSettledShare;
  round.passing.emplace_back(i, std::move(*fitted));
}

// Refits: the best few by linear score, and, unless one of them leaves only noise, every other
// candidate too. A linear score can hide the right effect: one nearly collinear with the law's
// terms (Hertz's z^1.5 between k1 z and k3 z^3), or one whose derivative where it is off is a
// series spring that k1 absorbs (the stator, which its dip search refits); a weaker effect that
// passes first then takes its place (docs/loop.md, campaign). The passing ones, largest
// criterion rise first.
round_refits refit_round(trace_run& run, std::vector<scored>& cands) {
  const trace_settings& s = run.c.s;
  round_refits round;
  for (std::size_t i = 0; i < std::min<std::size_t>(static_cast<std::size_t>(s.refit_candidates), cands.size()) && !round.noise_left; ++i) {
    if (cands[i].candidate.score < kRefitScoreShare * cands.front().candidate.score || !cands[i].candidate.verdict.empty()) break;
    try_refit(run, cands, i, false, round);
  }
  if (!round.noise_left && !round.most_explained) {
    s.progress(round.passing.empty() ? "      nothing passes; refitting the others ..." : "      none leaves only noise; refitting the others ...");
    for (std::size_t i = 0; i < cands.size() && !round.noise_left; ++i)
      if (!cands[i].candidate.refitted && cands[i].candidate.verdict.empty()) try_refit(run, cands, i, true, round);
  } else if (!round.noise_left) {
    // Most of the excess removed, but not to the noise: a stand-in may have taken the place of an
    // effect whose linear score hides it (a stator's compliance is a series spring k1 absorbs;
    // Hunt-Crossley damping passed first on a stator's record, with 98 % of the excess, and
    // beside it the stator no longer fits). Such effects are refitted by their dip search in this
    // round too, and the larger criterion rise is added.
    for (std::size_t i = 0; i < cands.size() && !round.noise_left; ++i) {
      const auto ec = effect_coordinates(*cands[i].effect);
      if (!cands[i].candidate.refitted && cands[i].candidate.verdict.empty() && dip_searched(ec) != ec.end()) {
        s.progress("      most of the excess is removed, not to the noise: the dip search of " + cands[i].candidate.name + " too ...");
        try_refit(run, cands, i, true, round);
      }
    }
  }
  std::stable_sort(round.passing.begin(), round.passing.end(),
                   [&](const auto& a, const auto& b) { return cands[a.first].candidate.bic_drop > cands[b.first].candidate.bic_drop; });
  return round;
}

// A round's choice: the candidate added (with its fit) and its rival, or a rescore on a better base.
struct round_choice {
  std::optional<std::size_t> chosen;
  std::optional<fitted_model> fit;
  std::string rival;  // another needed candidate within min_criterion_rise of the chosen one's criterion
  bool rescore = false;
};

// Whether a candidate that passed the significance rule is needed: the fair comparison, then out of
// sample. Where the fair comparison finds a better base and `may_rescore`, that base replaces the
// current model (the round is scored again on it).
enum class judged_as { needed, not_needed, rescore };
judged_as judge_candidate(trace_run& run, const scored& sc, effect_candidate& cand, const fitted_model& with, bool may_rescore) {
  const round_context& c = run.c;
  // Fair comparison: the winner's refit moves the base coordinates too, and may gain only because
  // the base leaves a local minimum of its own (a misorientation record's before-fit,
  // docs/loop.md). The base is refitted without the effect from where the winner ended; if that
  // lands lower, the winner must pass the rule against it too.
  fitted_model reference = run.current;
  const fit_problem refit_base = make_problem(c.predictor, c.dwells, run.current.at, run.current.coords, c.noise);
  const fit_result b = fit(refit_base, refit_base.of(switched_off(with.at, *sc.effect)), c.s.max_jacobians, &with.orbits);
  if (auto judged = on_the_datas_orbits(c, refit_base, b); judged && judged->rss() < run.current.rss()) reference = std::move(*judged);
  // A second effect only on evidence the first cannot give: the effects already in the model get
  // their shapes' global search again from there, and the candidate must pass against the
  // better-fitted model (a stator held at the wrong mass left room for a stand-in).
  for (const auto& step : run.out.effects)
    if (!shapes_of(reference.coords, step.effect, false).empty()) settle_shapes(c, reference, step.effect, false);
  significance fair = test(c, reference, with);
  if (!fair.pass() && fair.judged.on_margin) run.on_the_margin(cand.name, "its fair comparison " + fair.judged.reason);
  if (!fair.pass()) {
    cand.verdict = "the model without it, refitted from where its refit ended, explains its gain (BIC drop " + format_digits(fair.bic_drop()) + ", share " +
                   format_digits(fair.excess_share()) + ")";
    if (may_rescore && reference.rss() < run.current.rss() && run.base_restarts < kMaxBaseRestarts) {
      ++run.base_restarts;
      run.note("the model without " + cand.name + ", refitted from where its refit ended, explains its gain: the round is scored again on it");
      run.current = std::move(reference);
      // Still the paper's model: its best fit is the "before".
      if (run.out.effects.empty()) run.out.before = run.current.at, run.out.before_orbits = run.current.orbits;
      return judged_as::rescore;
    }
    return judged_as::not_needed;
  }
  c.s.progress("      " + cand.name + " passes the fair comparison (BIC drop " + format_digits(fair.bic_drop()) + "); out of sample ...");
  const statistic held_out = holdout_gain(c, reference, with);
  if (std::isnan(held_out.value)) {  // untested is not passed: tentative, and not added
    cand.verdict = "not tested out of sample: the model without it cannot be computed on a held-out fold";
    run.on_the_margin(cand.name, cand.verdict);
    return judged_as::not_needed;
  }
  cand.holdout_gain = held_out.value;
  fair.comparison.holdout_gain = held_out.value;
  fair.comparison.holdout_gain_uncertainty = held_out.uncertainty;
  fair.comparison.in_sample_gain = (reference.rss() - with.rss()) / (c.noise * c.noise);
  fair.comparison.in_sample_gain_uncertainty = (reference.uncertainty + with.uncertainty) / (c.noise * c.noise);
  cand.holdout_gain_uncertainty = held_out.uncertainty;
  cand.in_sample_gain = fair.comparison.in_sample_gain;
  cand.in_sample_gain_uncertainty = fair.comparison.in_sample_gain_uncertainty;
  c.s.progress("      out of sample it gains chi^2 " + format_digits(held_out.value, 3) + " +- " + format_digits(held_out.uncertainty, 2) + ", on all data " +
               format_digits(cand.in_sample_gain, 3) + " +- " + format_digits(cand.in_sample_gain_uncertainty, 2));
  const need needed = judge_need(fair.comparison, c.s.rules);
  cand.verdict = needed.needed ? "added" : needed.reason;
  if (needed.on_margin) run.on_the_margin(cand.name, needed.needed ? "added on the margin: " + needed.reason : needed.reason);
  return needed.needed ? judged_as::needed : judged_as::not_needed;
}

// The best passing candidate that is needed (fair comparison, out of sample); then the
// decisive-choice rule: a later passing one whose model comes within min_criterion_rise of the
// chosen one's criterion, and is needed too, explains the records alike (its rival).
round_choice choose(trace_run& run, std::vector<scored>& cands, round_refits& round) {
  round_choice out;
  std::size_t k = 0;
  for (; k < round.passing.size(); ++k) {
    auto& [i, with] = round.passing[k];
    const judged_as j = judge_candidate(run, cands[i], cands[i].candidate, with, true);
    if (j == judged_as::rescore) {
      out.rescore = true;
      return out;
    }
    if (j == judged_as::needed) {
      out.chosen = i;
      break;
    }
  }
  if (!out.chosen) return out;
  const fitted_model& chosen_fit = round.passing[k].second;
  const double chosen = criterion_of(run.c, chosen_fit);
  for (std::size_t r = k + 1; r < round.passing.size(); ++r) {
    auto& [i, with] = round.passing[r];
    const decision apart = decisive(chosen, criterion_of(run.c, with), run.c.s.rules,
                                    criterion_change_uncertainty(run.c.rows, chosen_fit.rss(), chosen_fit.uncertainty, with.rss(), with.uncertainty));
    if (apart.on_margin) run.on_the_margin(cands[i].candidate.name, "its criterion against " + cands[*out.chosen].candidate.name + "'s lies on the decisive margin");
    if (apart.yes) break;  // sorted by criterion rise: the rest are further
    if (judge_candidate(run, cands[i], cands[i].candidate, with, false) == judged_as::needed) {
      cands[i].candidate.verdict = "needed too, within the decisive margin of " + cands[*out.chosen].candidate.name + "'s criterion: its rival";
      out.rival = cands[i].candidate.name;
      break;
    }
  }
  out.fit = std::move(round.passing[k].second);
  return out;
}

// The chosen candidate into the model, with its round's scores and the others that passed.
void add_chosen(trace_run& run, const std::vector<scored>& cands, const round_refits& round, round_choice& choice) {
  const effect_candidate& chosen = cands[*choice.chosen].candidate;
  loop_step step;
  step.effect = chosen.name;
  step.error_after_adding = chosen.error_after;
  step.bic_drop = chosen.bic_drop;
  step.excess_share = chosen.excess_share;
  step.holdout_gain = chosen.holdout_gain;
  step.rival = choice.rival;
  for (const auto& sc : cands) step.candidates.push_back(sc.candidate);
  for (const auto& [i, m] : round.passing)
    if (i != *choice.chosen) step.alternatives.push_back(cands[i].candidate.name);
  run.out.effects.push_back(std::move(step));
  run.remaining.erase(std::find(run.remaining.begin(), run.remaining.end(), cands[*choice.chosen].effect));
  run.current = std::move(*choice.fit);
  run.polished = false;
}

// Backward elimination: an earlier effect that the model no longer needs (the new one explains
// what it did) is taken out, the weakest first, one per round.
void eliminate_backward(trace_run& run) {
  const round_context& c = run.c;
  auto& effects = run.out.effects;
  if (effects.size() < 2) return;
  std::optional<std::pair<std::size_t, fitted_model>> weakest;
  double weakest_drop = std::numeric_limits<double>::infinity();
  significance weakest_sig;
  for (std::size_t a = 0; a + 1 < effects.size(); ++a) {
    const effect_info& e = find_effect(effects[a].effect);
    const auto coords = without_effect(run.current.coords, e.name);
    const model_point from = switched_off(run.current.at, e);
    const fit_problem problem = make_problem(c.predictor, c.dwells, from, coords, c.noise);
    const fit_result f = fit(problem, problem.of(from), c.s.max_jacobians, &run.current.orbits);
    if (!f.ok) continue;
    auto judged = judge(c, f.at, coords, &f);
    if (!judged) continue;
    const significance sig = test(c, *judged, run.current);
    if (sig.judged.on_margin) run.on_the_margin(effects[a].effect, "kept or removed on the margin: " + sig.judged.reason);
    if (!sig.pass() && sig.bic_drop() < weakest_drop) weakest_drop = sig.bic_drop(), weakest_sig = sig, weakest.emplace(a, std::move(*judged));
  }
  if (!weakest) return;
  const std::string name = effects[weakest->first].effect;
  run.note(name + " is no longer needed with " + effects.back().effect + " (it gains BIC " + format_digits(weakest_sig.bic_drop()) + ", share " +
           format_digits(weakest_sig.excess_share()) + " over the refit without it): removed");
  run.out.removed.push_back({name, effects.size(), weakest_sig.bic_drop(), weakest_sig.excess_share(), ""});
  effects.erase(effects.begin() + static_cast<std::ptrdiff_t>(weakest->first));
  run.current = std::move(weakest->second);
}

// Exchange: forward selection can add a stand-in first (a probe runout's 1X and 2X readings beat a
// shaft bow while a 2X misalignment is still missing, and then hold the bow's place). Every
// earlier effect is refitted with each effect that also passed in its round in its place; the
// best exchange that the decisive-choice rule prefers (the criterion lower by more than
// min_criterion_rise) is made.
void exchange_stand_ins(trace_run& run) {
  const round_context& c = run.c;
  auto& effects = run.out.effects;
  if (effects.size() < 2) return;
  const auto in_model = [&](std::string_view name) {
    return std::any_of(effects.begin(), effects.end(), [&](const loop_step& e) { return e.effect == name; });
  };
  struct exchange {
    std::size_t slot;
    const effect_info* by;
    fitted_model model;
  };
  std::optional<exchange> best;
  const double now = criterion_of(c, run.current);
  double best_criterion = now;
  for (std::size_t a = 0; a + 1 < effects.size(); ++a) {
    const effect_info& was = find_effect(effects[a].effect);
    for (const auto& name : effects[a].alternatives) {
      const effect_info& by = find_effect(name);
      const auto ec = effect_coordinates(by);
      const bool searched = std::any_of(ec.begin(), ec.end(), [](const fit_coordinate& q) { return q.search || q.trials; });
      if (in_model(name) || searched) continue;  // a searched effect needs its own starts (its round's refit)
      auto coords = without_effect(run.current.coords, was.name);
      coords.insert(coords.end(), ec.begin(), ec.end());
      const model_point from = switched_off(switched_off(run.current.at, was), by);
      const fit_problem problem = make_problem(c.predictor, c.dwells, from, coords, c.noise);
      const fit_result f = fit(problem, problem.of(from), c.s.max_jacobians, &run.current.orbits);
      if (!f.ok) continue;
      auto judged = judge(c, f.at, coords, &f);
      if (!judged || documented_strength(by, judged->at) < c.s.rules.min_documented_level || outside_fit_range(by, judged->at)) continue;
      const double b = criterion_of(c, *judged);
      const decision apart = decisive(b, now, c.s.rules, criterion_change_uncertainty(c.rows, judged->rss(), judged->uncertainty, run.current.rss(), run.current.uncertainty));
      if (apart.on_margin) run.on_the_margin(std::string(by.name), "its exchange for " + std::string(was.name) + " lies on the decisive margin");
      if (b < best_criterion && apart.yes) best_criterion = b, best = exchange{a, &by, std::move(*judged)};
    }
  }
  if (!best) return;
  loop_step& slot = effects[best->slot];
  run.note(std::string(best->by->name) + " in place of " + slot.effect + " lowers BIC by " + format_digits(now - best_criterion - c.s.rules.min_criterion_rise) +
           " beyond the decisive margin: exchanged");
  run.out.removed.push_back({slot.effect, effects.size(), 0.0, 0.0, std::string(best->by->name)});
  run.remaining.erase(std::find(run.remaining.begin(), run.remaining.end(), best->by));
  run.remaining.push_back(&find_effect(slot.effect));
  slot.alternatives.erase(std::find(slot.alternatives.begin(), slot.alternatives.end(), std::string(best->by->name)));
  slot.alternatives.push_back(slot.effect);
  slot.exchanged_for = slot.effect;
  slot.effect = std::string(best->by->name);
  slot.rival.clear();  // it won by more than the decisive margin
  run.current = std::move(best->model);
  slot.error_after_adding = errors_of(c.dwells, c.predictor, run.current.r).nrmse_contact;
  run.polished = false;
}

// One round: score, refit, choose, add (then eliminate and exchange). A round that adds nothing
// leaves its candidates as the result's last round.
enum class round_end { added, rescore, nothing };
round_end run_round(trace_run& run, int round) {
  const round_context& c = run.c;
  c.s.progress("[2/3] trace round " + std::to_string(round) + ": scoring " + std::to_string(run.remaining.size()) + " effects (" +
               std::to_string(c.predictor.evaluations()) + " model evaluations so far) ...");
  std::vector<scored> cands = score_round(run);
  if (cands.empty()) return round_end::nothing;
  c.s.progress("      best scores: " + cands[0].candidate.name + (cands.size() > 1 ? ", " + cands[1].candidate.name : std::string()) + "; refitting ...");
  round_refits refits = refit_round(run, cands);
  round_choice choice = choose(run, cands, refits);
  if (choice.rescore) return round_end::rescore;
  if (!choice.chosen) {
    for (auto& sc : cands)
      if (sc.candidate.verdict.empty()) sc.candidate.verdict = sc.candidate.refitted ? "fails the significance rule" : "not refitted (score)";
    for (const auto& sc : cands) run.out.last_round.push_back(sc.candidate);
    return round_end::nothing;
  }
  add_chosen(run, cands, refits, choice);
  eliminate_backward(run);
  exchange_stand_ins(run);
  return round_end::added;
}

}  // namespace

void trace_settings::validate() const {
  check({"trace", "max_effects"}, max_effects);
  check({"trace", "refit_candidates"}, refit_candidates);
  rules.validate();
  check({"trace", "orders"}, orders);
  check({"trace", "whiteness_lags"}, whiteness_lags);
  check({"trace", "max_jacobians"}, max_jacobians);
  check({"trace", "profile_points"}, profile_points);
  orbits.validate();
}

const effect_parameter_info* outside_fit_range(const effect_info& e, const model_point& m) {
  if (!has_effect(m.fx, e)) return nullptr;
  for (const auto& q : e.parameters) {
    const double v = m.fx.*q.member;
    if (q.is_switch && v == q.off) continue;
    if (v < q.lo || v > q.hi) return &q;
  }
  return nullptr;
}

std::vector<std::pair<std::string, double>> effect_params(const effect_info& e, const effect_parameters& fx) {
  std::vector<std::pair<std::string, double>> out;
  for (const auto& q : e.parameters) out.emplace_back(std::string(q.key), fx.*q.member);
  return out;
}

trace_result trace(const std::vector<loop_dwell>& dwells, orbit_predictor& predictor, double noise, const model_point& staged,
                   const fit_result& before, const trace_settings& s) {
  const round_context c{dwells, predictor, noise, static_cast<double>(predictor.orbit_rows()), staged, s};
  auto start = judge(c, before.at, paper_coordinates(), &before);
  if (!start) throw numerical_error("the loop's model cannot be computed at its own before-fit");
  trace_run run{c, {}, std::move(*start), {}};
  run.out.before = before.at;
  run.out.before_orbits = run.current.orbits;
  run.out.before_uncertainty = run.current.uncertainty;
  for (const auto& e : effect_library()) run.remaining.push_back(&e);
  int round = 0;
  while (!run.is_noise(run.current) && static_cast<int>(run.out.effects.size()) < s.max_effects && !run.remaining.empty()) {
    ++round;
    if (!run.out.effects.empty() && !run.polished) {
      run.polished = true;
      if (polish_from_the_staged_start(run) && run.is_noise(run.current)) break;
    }
    const round_end end = run_round(run, round);
    if (end == round_end::rescore) --round;
    if (end == round_end::nothing) break;
  }
  // Whether the records determine each named effect's shapes: their profiles on the final model
  // (which a profile that lands lower moves, and the later ones are then taken there).
  for (auto& step : run.out.effects) {
    if (shapes_of(run.current.coords, step.effect, true).empty()) continue;
    s.progress("[2/3] profiles of " + step.effect + "'s shape parameters (" + std::to_string(predictor.evaluations()) + " model evaluations so far) ...");
    step.profiles = settle_shapes(c, run.current, step.effect, true);
  }
  run.out.after = run.current.at;
  run.out.after_orbits = run.current.orbits;
  run.out.after_uncertainty = run.current.uncertainty;
  for (auto& step : run.out.effects)  // the final estimates (later effects refine earlier ones)
    step.params = effect_params(find_effect(step.effect), run.current.at.fx);
  return std::move(run.out);
}

}  // namespace rubref
