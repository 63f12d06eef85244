// Where clients find tribod when told nothing else (config/tribod.textproto
// uses the same port). TRIBO_ADDRESS=host:port overrides it for clients.
#pragma once

#include <cstdint>

namespace tribo::wire {

inline constexpr const char* kDefaultHost = "127.0.0.1";
inline constexpr std::uint16_t kDefaultPort = 7460;
inline constexpr std::uint32_t kApiVersion = 1;

}  // namespace tribo::wire
