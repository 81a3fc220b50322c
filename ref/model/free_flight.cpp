// The free flights of the rotor (4 states) and of the rotor with a stator of its own mass (6),
// compiled once here (declared `extern` in free_flight.hpp).
#include "ref/model/free_flight.hpp"

namespace rubref {

template class free_flight<4>;
template class free_flight<6>;

}  // namespace rubref
