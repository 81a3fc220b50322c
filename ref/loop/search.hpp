#pragma once
// Searches for effects a local fit cannot reach from "off" (docs/loop.md, trace): the profile of
// an effect along its trial values, and the dip search of a ringing stator's ring frequency.

#include <functional>
#include <string>
#include <vector>

#include "ref/loop/fit.hpp"

namespace rubref {

// The best value along a trial grid: `left(value)` is what the residual leaves there (0 is the
// effect off, leaving `at_off`); the trials, then golden-section steps between the best one's
// neighbours (in the logarithm where both are positive). left() may return +inf where the model
// cannot be computed.
struct profile_best {
  double value = 0.0;
  double left = 0.0;
};
profile_best profile(const std::vector<double>& trials, double at_off, const std::function<double(double)>& left);

// The refit of an effect whose coordinate `j` of `problem` (its base: the current model, the
// effect off, leaving `base_rss`) has a dip search: the envelope on `staged`'s paper part (the
// staged model while no effect is in the model: a fit without the effect has bent the current one
// towards the contacts; the current model once effects have brought it closer), fits from its best
// values, then hops between dips while a refit lands lower. Returns the lowest fit.
fit_result search_dips(const fit_problem& problem, std::size_t j, double base_rss, const model_point& staged,
                       const std::vector<loop_dwell>& dwells, int max_iterations, const std::function<void(const std::string&)>& progress);

}  // namespace rubref
