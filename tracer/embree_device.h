#pragma once
// One Embree device per process (creating a device spins up its own thread pool and caches;
// several would fight over the 2 cores). Created on first use with the error callback
// installed, as in Embree's minimal tutorial.

#include <embree3/rtcore.h>

#include <string>

namespace parallax {

// The process-wide device; thread-safe first use. Throws InternalError if Embree cannot start.
RTCDevice embreeDevice();

// Throws InternalError carrying Embree's message when the callback has recorded an error since
// the last call (Embree reports errors through the callback, not through return values).
void throwIfEmbreeFailed(const std::string& during);

}  // namespace parallax
