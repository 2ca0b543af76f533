// The small part of YAML that the calibration's object file uses (docs/calibration.md, "The object
// file"): block mappings by indentation, flow sequences [a, b] and flow mappings {k: v}, plain or
// quoted scalars, # comments. No block sequences ("- item"), anchors or multi-line scalars: those
// are errors naming the line.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace collision_response::calibration {

struct YamlNode {
  enum class Kind { kScalar, kSequence, kMapping };
  Kind kind = Kind::kScalar;
  std::string scalar;                                 ///< kScalar: the text, unquoted
  std::vector<YamlNode> items;                        ///< kSequence
  std::vector<std::pair<std::string, YamlNode>> map;  ///< kMapping, in file order
  int line = 0;                                       ///< 1-based line where the node starts

  /// The mapping's member `key`, or nullptr (also when this is not a mapping).
  const YamlNode* find(const std::string& key) const;
};

/// Parses `text`; throws std::runtime_error "<source>:<line>: <what>" on anything outside the
/// subset above or a repeated key. The top level is a mapping.
YamlNode parseYaml(const std::string& text, const std::string& source);

}  // namespace collision_response::calibration
