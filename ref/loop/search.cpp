#include "ref/loop/search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ref/format/record.hpp"

namespace rubref {

namespace {
// Golden-section steps of a profile between two trial values: the bracket shrinks to
// 0.618^10 < 1 % of its width, a start well inside the refit's reach.
constexpr int kProfileIterations = 10;
// A dip search's hops: the hops at most, and the share of the residual a hop must land below.
// From a fit in a wrong dip, the right one was the lowest of its scan's other dips in every hop
// docs/loop.md measures, so one dip is refitted per hop (each refit is a fit of every
// coordinate); the stator's dips differ by factors of 1.5-3.5, and a hop that gains less than
// 10 % follows a slope the fit already descends, not a comb.
constexpr int kSearchHops = 4;
constexpr double kHopGain = 0.9;
// Iterations of the fit of the profiled coordinates at each envelope value: a few coordinates
// and the shifts, from the staged model; enough to rank the values, the fit from the best one
// goes on.
constexpr int kEnvelopeIterations = 3;
// Fits of every coordinate from this many of the envelope's best points.
constexpr std::size_t kEnvelopeStarts = 2;
}  // namespace

profile_best profile(const std::vector<double>& trials, double at_off, const std::function<double(double)>& left) {
  std::vector<std::pair<double, double>> tried{{0.0, at_off}};  // (value, residual left); 0 is off
  for (const double value : trials) tried.emplace_back(value, left(value));
  std::sort(tried.begin(), tried.end());
  const auto best_at = static_cast<std::size_t>(
      std::min_element(tried.begin(), tried.end(), [](const auto& a, const auto& b) { return a.second < b.second; }) - tried.begin());
  const double lo = tried[best_at == 0 ? 0 : best_at - 1].first, hi = tried[std::min(best_at + 1, tried.size() - 1)].first;
  const bool geometric = lo > 0.0;  // magnitudes a decade apart: search their logarithm
  const auto value_at = [&](double x) { return geometric ? std::exp(x) : x; };
  double a = geometric ? std::log(lo) : lo, b = geometric ? std::log(hi) : hi;
  profile_best best{tried[best_at].first, tried[best_at].second};
  constexpr double kGolden = 0.6180339887498949;
  double x1 = b - kGolden * (b - a), x2 = a + kGolden * (b - a), f1 = left(value_at(x1)), f2 = left(value_at(x2));
  for (int it = 0; it < kProfileIterations; ++it) {
    if (f1 < f2) b = x2, x2 = x1, f2 = f1, x1 = b - kGolden * (b - a), f1 = left(value_at(x1));
    else a = x1, x1 = x2, f1 = f2, x2 = a + kGolden * (b - a), f2 = left(value_at(x2));
  }
  for (const auto& [x, f] : {std::pair{x1, f1}, std::pair{x2, f2}})
    if (f < best.left) best = {value_at(x), f};
  return best;
}

fit_result search_dips(const fit_problem& problem, std::size_t j, double base_rss, const model_point& staged,
                       const std::vector<loop_dwell>& dwells, int max_iterations, const std::function<void(const std::string&)>& progress) {
  const fit_coordinate& coordinate = problem.coords[j];
  const auto& search = *coordinate.search;
  orbit_predictor& predictor = *problem.predictor;
  // The envelope on the staged model (the linear part from the dwells without contact, which the
  // effect does not reach; a fit without the effect has bent it towards the contacts).
  std::vector<fit_coordinate> profiled;
  for (const auto& name : search.profiled)
    for (const auto& c : problem.coords)
      if (c.name == name) profiled.push_back(c);
  const fit_coordinate* alternate = nullptr;
  for (const auto& c : problem.coords)
    if (c.name == search.alternate) alternate = &c;
  std::vector<std::optional<double>> alternates{std::nullopt};
  if (alternate) {
    alternates.clear();
    for (const double v : search.alternate_values) alternates.emplace_back(v);
  }
  std::vector<std::pair<double, std::pair<fit_result, double>>> envelope;  // (residual, (fit, value)), lowest first
  // The envelope's base (the caller's choice, search_dips): the staged model's paper part, or the
  // current model.
  model_point base = problem.base;
  base.p = staged.p;
  for (const double value : search.envelope)
    for (const auto& other : alternates) {
      model_point m = base;
      search.switch_on(m);
      coordinate.set(m, value);
      if (other) alternate->set(m, *other);
      const fit_problem inner = make_problem(predictor, dwells, m, profiled, problem.noise);
      const fit_result f = fit(inner, inner.of(m), kEnvelopeIterations);
      if (!f.ok) continue;
      // Ranked on its own orbits found from the data, as every refit is judged; in harmonics (the
      // ranking's differences are the samples', the band's offset aside).
      predictor.anchor(f.at);
      if (const auto r = predictor.harmonic_residuals(f.at)) envelope.push_back({r->squaredNorm(), {f, value}});
    }
  if (envelope.empty()) return fit_result{};
  std::stable_sort(envelope.begin(), envelope.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  // On the better of its own orbits and those found from the data (as the trace judges a refit).
  const auto judged = [&](fit_result f) {
    if (!f.ok) return f;
    const auto r = residual_at(predictor, f.at);
    if (r && !(f.r.size() > 0 && f.r.squaredNorm() <= r->squaredNorm())) {
      f.r = *r;
      f.rss = r->squaredNorm();
      f.orbits = predictor.last_orbits();
    }
    return f;
  };
  // Fits of every coordinate from the best few envelope points: the best one alone landed in a
  // basin of the law's own damping standing in for the stator's on a campaign-like record.
  fit_result at;
  double start_value = 0.0;
  for (std::size_t i = 0; i < std::min(envelope.size(), kEnvelopeStarts); ++i) {
    const fit_result f = judged(fit(problem, problem.of(envelope[i].second.first.at), max_iterations));
    if (f.ok && f.rss < at.rss) at = f, start_value = envelope[i].second.second;
  }
  if (!at.ok) return at;
  progress("      " + coordinate.name + ": envelope best " + format_digits(coordinate.natural(start_value)) + ", fitted " +
           format_digits(coordinate.natural(coordinate.get(at.at))) +
           " (residual " + format_digits(at.rss) + " m^2, without the effect " + format_digits(base_rss) + ")");
  // Hops refine a fit that explains more than the model without the effect; one that explains
  // less sits in no dip worth refining.
  if (!(at.rss < base_rss)) return at;
  const int steps = static_cast<int>(std::log(search.factor) / search.step);
  for (int hop = 0; hop < kSearchHops; ++hop) {
    predictor.anchor(at.at, at.orbits);
    const double value = coordinate.natural(coordinate.get(at.at));
    std::vector<std::pair<double, double>> scan;  // (natural value, residual)
    for (int i = -steps; i <= steps; ++i) {
      model_point q = at.at;
      const double v = value * std::exp(i * search.step);
      coordinate.set(q, coordinate.chart(v));
      const auto r = predictor.harmonic_residuals(q);  // dips are found by differences: in harmonics
      scan.emplace_back(v, r ? r->squaredNorm() : std::numeric_limits<double>::infinity());
    }
    std::vector<std::pair<double, double>> dips;  // (residual, value), lowest first
    for (std::size_t i = 1; i + 1 < scan.size(); ++i)
      if (scan[i].second < scan[i - 1].second && scan[i].second < scan[i + 1].second && std::abs(std::log(scan[i].first / value)) > 4.0 * search.step)  // four steps: the fit's own dip
        dips.emplace_back(scan[i].second, scan[i].first);
    std::sort(dips.begin(), dips.end());
    if (dips.empty()) break;
    model_point q = at.at;
    coordinate.set(q, coordinate.chart(dips.front().second));
    const fit_result next = judged(fit(problem, problem.of(q), max_iterations, &at.orbits));
    if (!(next.ok && next.rss < kHopGain * at.rss)) break;
    at = next;
    progress("      " + coordinate.name + ": hop " + std::to_string(hop + 1) + " to " + format_digits(coordinate.natural(coordinate.get(at.at))) +
             " (residual " +
             format_digits(at.rss) + " m^2)");
  }
  return at;
}

}  // namespace rubref
