#pragma once
// The paper's model fitted to the dwells (docs/loop.md, step 2): the staged start (the linear part
// by harmonic balance on the dwells without contact, then the identified law's terms by the
// paper's FROLS on the contact forces, Eq. 3-5) and the "before" fit of every coordinate together
// on the orbits of every dwell, from several starts.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ref/loop/fit.hpp"
#include "ref/loop/preprocess.hpp"

namespace rubref {

// The linear part of Eq. 1 from the dwells without contact (harmonic balance on their 1X), with
// its stiffnesses and dampers bounded below by a physical floor (noted in `notes` when active).
parameters fit_linear_harmonic(const std::vector<loop_dwell>& dwells, double mass, std::vector<std::string>* notes = nullptr);

// The staged model (`model`): the linear part from the dwells without contact, the law from the
// weak form refined by identify's orbit fit (where its coefficients are positive, else the paper's
// Table 2), mu likewise. `weak_form`: its parameters with the weak form's own law and mu, where the
// orbit fit moved them (another start of the before-fit: from neither law does the before-fit land
// lower on every record, docs/loop.md).
struct staged_start {
  model_point model;
  std::optional<parameters> weak_form;
};
// The staged start of the dwells; notes what it could not do.
staged_start staged_model(const std::vector<loop_dwell>& dwells, double mass, std::vector<std::string>& notes);

// The before-fit's starts, in the order that breaks their ties: the staged model, the staged
// linear part with Table 2's law, and the staged model with the weak form's law (where it has one).
std::vector<named_start> before_fit_starts(const model_point& staged, const std::optional<parameters>& weak_form);

// The dwells whose model orbit cannot be computed at any of `starts` (Newton shooting and a
// transient from the measured state both fail there): a fit cannot compare what the model cannot
// give, so the loop leaves them out, with this reason.
std::vector<std::size_t> uncomputable_dwells(const std::vector<loop_dwell>& dwells, double noise, const std::vector<named_start>& starts,
                                             const fit_orbit_options& orbits = {});

// The dwells that repeat every n > 1 revolutions where the model has no period-n orbit at any of
// `starts` (Newton on the n-revolution map fails; a transient from the measured state settles
// elsewhere): such a dwell cannot guide a fit of orbits until the model has its orbit, and its
// transient would bend every coordinate towards another attractor.
std::vector<std::size_t> dwells_without_their_orbit(const std::vector<loop_dwell>& dwells, double noise, const std::vector<named_start>& starts,
                                                    const fit_orbit_options& orbits = {});

// The before-fit: every coordinate of the paper's model, by the solver (fit.hpp) from the best of
// its starts, and, while the fit leaves more than the noise, from the others too. The lowest fit wins; it is never worse than the best
// start (every accepted step lowers the residual).
// `is_noise` tells a fit whose residual passes the validity checks (the predictor holds its states).
multistart_result fit_paper_model(orbit_predictor& predictor, const std::vector<loop_dwell>& dwells, const model_point& staged,
                                  const std::optional<parameters>& weak_form, double noise, int max_iterations,
                                  const std::function<bool(const fit_result&)>& is_noise);

}  // namespace rubref
