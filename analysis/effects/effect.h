// The vocabulary of effects the residual diagnosis can name (the effects the dissertation names: Srivastava 2006, §2.1, §3.3, §4.4),
// shared with the simulated instrument's effect switches: the names
// are a contract of the tribo-fit JSON output.
#pragma once

#include <array>
#include <optional>
#include <string_view>

namespace tribo::analysis {

enum class Effect {
  kDwellStiction,          // static friction grows with the contact age (the rest before motion onset)
  kFrictionalLag,          // the velocity dependence acts with a time delay
  kVelocityStrengthening,  // friction grows with log velocity (thermal activation)
  kLoadDependence,         // friction not proportional to the normal load
  kPositionPeriodic,       // friction (or a force ripple) periodic in position
  kDirectionAsymmetry,     // friction levels differ between the two directions
  kTiltOffset,             // a lateral force N tan(theta) from a tilted tip
  kDrift,                  // a slow lateral-force drift in time
  kPreslidingHysteresis,   // elasto-plastic presliding (elastic unloading, breakaway)
  kBacklash,               // a dead zone after reversals (play in series)
  kRateState,              // rate-and-state friction: direct effect a ln v, evolution b ln(v theta/Dc)
};

inline constexpr std::array<Effect, 11> kAllEffects = {
    Effect::kDwellStiction,      Effect::kFrictionalLag,  Effect::kVelocityStrengthening,
    Effect::kLoadDependence,     Effect::kPositionPeriodic, Effect::kDirectionAsymmetry,
    Effect::kTiltOffset,         Effect::kDrift,          Effect::kPreslidingHysteresis,
    Effect::kBacklash,           Effect::kRateState};

constexpr std::string_view effect_name(Effect e) {
  switch (e) {
    case Effect::kDwellStiction: return "dwell_stiction";
    case Effect::kFrictionalLag: return "frictional_lag";
    case Effect::kVelocityStrengthening: return "velocity_strengthening";
    case Effect::kLoadDependence: return "load_dependence";
    case Effect::kPositionPeriodic: return "position_periodic";
    case Effect::kDirectionAsymmetry: return "direction_asymmetry";
    case Effect::kTiltOffset: return "tilt_offset";
    case Effect::kDrift: return "drift";
    case Effect::kPreslidingHysteresis: return "presliding_hysteresis";
    case Effect::kBacklash: return "backlash";
    case Effect::kRateState: return "rate_state";
  }
  return "";
}

inline std::optional<Effect> effect_from_name(std::string_view name) {
  for (Effect e : kAllEffects) {
    if (effect_name(e) == name) return e;
  }
  return std::nullopt;
}

}  // namespace tribo::analysis
