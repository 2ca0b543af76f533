// A peer's run in a child process with a time limit: a peer whose solver does not finish (Simbody's
// PLUS can take ever shorter sliding intervals) costs the sweep that limit, not the whole run.
#pragma once

#include <functional>

#include "peer_run.h"

namespace collision_response::bench {

/// Runs `run` in a forked child (the sweep is single-threaded) and returns its PeerRun (velocities,
/// impulses, time, note). If the child has not finished after `time_limit` [s] it is killed, and
/// the result has no velocities and a note saying so; likewise if it dies.
PeerRun runIsolated(const std::function<PeerRun()>& run, double time_limit);

}  // namespace collision_response::bench
