#pragma once
// Boost.Odeint for the library's steppers (ref/integrate/steppers.hpp) and the precompiled headers
// (cmake/precompiled.hpp), which must agree on the warnings silenced here.
//
// odeint's steppers hold stage buffers that a default-constructed stepper leaves unset, and
// controlled_runge_kutta copies such a stepper in its constructor: GCC 12 reports the copy of
// the not-yet-written buffers as (maybe-)uninitialized at odeint's own lines. They are written
// before they are read, so those two warnings are silenced for odeint's headers only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <boost/numeric/odeint.hpp>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
