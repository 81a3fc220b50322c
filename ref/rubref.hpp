#pragma once
// rubref's public C++ interface in one include (installed as <rubref/rubref.hpp>): the paper's
// model and its variants, integration, periodic orbits and their continuation, sweeps, spectra,
// records, identification, the virtual rig, the loop and validation against golden files.
// Each header can also be included alone (<rubref/ref/...>, <rubref/variants/...>);
// docs/architecture.md says which does what.

#include "ref/closed_form.hpp"
#include "ref/errors.hpp"
#include "ref/golden.hpp"
#include "ref/identification/identify.hpp"
#include "ref/loop/loop.hpp"
#include "ref/orbit_summary.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/parameter_io.hpp"
#include "ref/parameters.hpp"
#include "ref/record.hpp"
#include "ref/rig/rig.hpp"
#include "ref/simulate.hpp"
#include "ref/spectrum.hpp"
#include "ref/sweep.hpp"
#include "ref/validation/validate.hpp"
#include "ref/version.hpp"
#include "variants/all_variants.hpp"
