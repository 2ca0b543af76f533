#pragma once

// Conversions between the package's ROS messages and the core library's types. Pure copies: the
// core's validate() checks the values, with the same field names as the messages.

#include <collision_response/BodyState.h>
#include <collision_response/Contact.h>
#include <collision_response/ContactImpulse.h>
#include <collision_response/IslandReport.h>
#include <collision_response/SolverOptions.h>

#include "collision_response/body_state.h"
#include "collision_response/collision_solver.h"
#include "collision_response/contact.h"
#include "collision_response/contact_impulse.h"
#include "collision_response/solver_options.h"

namespace collision_response {

/// Pose and twist are taken as given, in whatever frame msg.frame_id names.
core::BodyState fromMsg(const BodyState& msg);
/// `frame_id` is the frame the state is expressed in.
BodyState toMsg(const core::BodyState& state, const std::string& frame_id);

core::Contact fromMsg(const Contact& msg);
ContactImpulse toMsg(const core::ContactImpulse& impulse);
IslandReport toMsg(const core::IslandReport& report);

/// Options of a request; zero fields take the value of `defaults`. Throws core::InvalidInput
/// ("options.law", "options.solver") for an unknown enumeration value.
core::SolverOptions fromMsg(const SolverOptions& msg, const core::SolverOptions& defaults);

}  // namespace collision_response
