#pragma once
// rubref's public C++ interface in one include (installed as <rubref/rubref.hpp>): the paper's
// model and its variants, integration, periodic orbits and their continuation, sweeps, spectra,
// records, identification, the virtual rig, the loop, validation against golden files, and
// parameter studies.
// Each header can also be included alone (<rubref/ref/...>, <rubref/variants/...>);
// docs/architecture.md says which does what.

#include "ref/analysis/orbit_summary.hpp"
#include "ref/analysis/spectrum.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/version.hpp"
#include "ref/format/record.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/inference/verdict.hpp"
#include "ref/identification/identify.hpp"
#include "ref/identification/identify_io.hpp"
#include "ref/loop/loop.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/model/parameters.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/rig/rig.hpp"
#include "ref/run/simulate.hpp"
#include "ref/study/study.hpp"
#include "ref/study/study_folder.hpp"
#include "ref/study/study_run.hpp"
#include "ref/sweep/sweep.hpp"
#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"
#include "variants/all_variants.hpp"
