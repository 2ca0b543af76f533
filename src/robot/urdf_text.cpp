#include "collision_response/robot/urdf_text.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "collision_response/core/errors.h"

namespace collision_response::robot {
namespace {

std::string hexByte(std::uint8_t byte) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02x", byte);
  return text;
}

[[noreturn]] void refuse(const std::string& xml, std::size_t at, const std::string& what) {
  std::size_t line = 1;
  for (std::size_t i = 0; i < at; ++i) line += xml[i] == '\n' ? 1 : 0;
  throw core::InvalidInput(
      "URDF", "byte " + std::to_string(at) + " (line " + std::to_string(line) + "): " + what);
}

}  // namespace

void requireUrdfText(const std::string& xml) {
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(xml.data());
  const std::size_t size = xml.size();
  std::size_t i = 0;
  while (i < size) {
    const std::uint8_t lead = bytes[i];
    if (lead == 0) refuse(xml, i, "a NUL character (an XML document cannot hold one)");
    if (lead < 0x80) {
      ++i;
      continue;
    }
    // The sequence's length and the range of its second byte (RFC 3629, section 4): the
    // narrower ranges after 0xe0, 0xed, 0xf0 and 0xf4 exclude overlong forms, surrogates and
    // code points beyond U+10FFFF.
    std::size_t length = 0;
    std::uint8_t low = 0x80, high = 0xbf;
    if (lead >= 0xc2 && lead <= 0xdf) {
      length = 2;
    } else if (lead >= 0xe0 && lead <= 0xef) {
      length = 3;
      if (lead == 0xe0) low = 0xa0;
      if (lead == 0xed) high = 0x9f;
    } else if (lead >= 0xf0 && lead <= 0xf4) {
      length = 4;
      if (lead == 0xf0) low = 0x90;
      if (lead == 0xf4) high = 0x8f;
    } else {
      refuse(xml, i, hexByte(lead) + " cannot start a UTF-8 sequence (the text must be UTF-8)");
    }
    // The continuation bytes the text has, then (if it ends inside the sequence) the missing ones.
    const std::size_t present = std::min(length, size - i);
    for (std::size_t k = 1; k < present; ++k) {
      const std::uint8_t next = bytes[i + k];
      const bool ok = k == 1 ? next >= low && next <= high : next >= 0x80 && next <= 0xbf;
      if (!ok) {
        refuse(xml, i + k,
               hexByte(next) + " is not a valid continuation of the UTF-8 sequence started by " +
                   hexByte(lead) + " at byte " + std::to_string(i) + " (the text must be UTF-8)");
      }
    }
    if (present < length) {
      refuse(xml, i,
             "a UTF-8 sequence cut short by the end of the text (" + hexByte(lead) + " needs " +
                 std::to_string(length - present) + " more byte(s))");
    }
    i += length;
  }
}

}  // namespace collision_response::robot
