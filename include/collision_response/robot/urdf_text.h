#pragma once

#include <string>

namespace collision_response::robot {

/// Checks that a URDF document's text can be handed to the XML parser, before it is: the text
/// must be UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing beyond U+10FFFF) and hold
/// no NUL character. XML 1.0 allows neither a NUL nor a broken UTF-8 sequence in a document
/// without an encoding declaration, and the parser urdf::Model uses (TinyXML 2.6) reads a
/// multi-byte sequence by its first byte's length: a sequence cut short at the end of the text
/// makes it read past the end of the buffer (found by the robot fuzz target). A NUL would end
/// the document there silently, dropping what follows it.
/// A document that declares another encoding (encoding="ISO-8859-1") is held to UTF-8 all the
/// same: ROS parameters, where robots' URDFs live, are UTF-8 text.
/// Throws core::InvalidInput naming the field "URDF", the byte's offset (from 0) and its line
/// (from 1): "URDF: byte 770 (line 18): a UTF-8 sequence cut short by the end of the text (0xf0
/// needs 3 more byte(s))".
void requireUrdfText(const std::string& xml);

}  // namespace collision_response::robot
