#include "collision_response/calibration/simple_yaml.h"

#include <stdexcept>

namespace collision_response::calibration {
namespace {

struct Line {
  int number;
  int indent;
  std::string text;  // without indentation and comment, right-trimmed
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

/// Cuts a # comment (one not inside quotes and at the start or after a blank).
std::string stripComment(const std::string& s) {
  char quote = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#' && (i == 0 || s[i - 1] == ' ' || s[i - 1] == '\t')) {
      return s.substr(0, i);
    }
  }
  return s;
}

class FlowParser {
 public:
  FlowParser(const std::string& text, const std::string& where) : s_(text), where_(where) {}
  YamlNode parse(int line) {
    YamlNode node = value(line);
    skip();
    if (i_ != s_.size()) fail("unexpected '" + s_.substr(i_) + "'");
    return node;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(where_ + ": " + what);
  }
  void skip() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t')) ++i_;
  }
  YamlNode value(int line) {
    skip();
    YamlNode node;
    node.line = line;
    if (i_ >= s_.size()) fail("a value is missing");
    if (s_[i_] == '[') {
      node.kind = YamlNode::Kind::kSequence;
      ++i_;
      skip();
      if (i_ < s_.size() && s_[i_] == ']') {
        ++i_;
        return node;
      }
      while (true) {
        node.items.push_back(value(line));
        skip();
        if (i_ < s_.size() && s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (i_ < s_.size() && s_[i_] == ']') {
          ++i_;
          return node;
        }
        fail("expected , or ] in a [sequence]");
      }
    }
    if (s_[i_] == '{') {
      node.kind = YamlNode::Kind::kMapping;
      ++i_;
      skip();
      if (i_ < s_.size() && s_[i_] == '}') {
        ++i_;
        return node;
      }
      while (true) {
        skip();
        const std::string key = scalar(true);
        skip();
        if (i_ >= s_.size() || s_[i_] != ':') fail("expected : after the key '" + key + "'");
        ++i_;
        for (const auto& [k, v] : node.map)
          if (k == key) fail("the key '" + key + "' appears twice");
        node.map.emplace_back(key, value(line));
        skip();
        if (i_ < s_.size() && s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (i_ < s_.size() && s_[i_] == '}') {
          ++i_;
          return node;
        }
        fail("expected , or } in a {mapping}");
      }
    }
    node.scalar = scalar(false);
    return node;
  }
  std::string scalar(bool key) {
    skip();
    if (i_ < s_.size() && (s_[i_] == '"' || s_[i_] == '\'')) {
      const char quote = s_[i_++];
      const auto end = s_.find(quote, i_);
      if (end == std::string::npos) fail("an unterminated quoted string");
      std::string out = s_.substr(i_, end - i_);
      i_ = end + 1;
      return out;
    }
    const size_t start = i_;
    while (i_ < s_.size() && s_[i_] != ',' && s_[i_] != ']' && s_[i_] != '}' &&
           !(key && s_[i_] == ':'))
      ++i_;
    const std::string out = trim(s_.substr(start, i_ - start));
    if (out.empty()) fail("an empty value");
    if (out[0] == '-' && out.size() > 1 && out[1] == ' ') fail("block sequences are not read");
    if (out[0] == '&' || out[0] == '*' || out[0] == '|' || out[0] == '>')
      fail("anchors, aliases and block scalars are not read");
    return out;
  }
  const std::string& s_;
  std::string where_;
  size_t i_ = 0;
};

YamlNode block(const std::vector<Line>& lines, size_t& at, int indent, const std::string& source) {
  YamlNode node;
  node.kind = YamlNode::Kind::kMapping;
  node.line = at < lines.size() ? lines[at].number : 0;
  while (at < lines.size() && lines[at].indent == indent) {
    const Line& line = lines[at];
    const std::string where = source + ":" + std::to_string(line.number);
    if (line.text[0] == '-') throw std::runtime_error(where + ": block sequences are not read");
    // The key ends at the first ": " or a trailing ':' outside quotes.
    size_t colon = std::string::npos;
    for (size_t i = 0; i < line.text.size(); ++i)
      if (line.text[i] == ':' && (i + 1 == line.text.size() || line.text[i + 1] == ' ')) {
        colon = i;
        break;
      }
    if (colon == std::string::npos) throw std::runtime_error(where + ": expected 'key: value'");
    std::string key = trim(line.text.substr(0, colon));
    if (key.size() >= 2 && (key[0] == '"' || key[0] == '\'') && key.back() == key[0])
      key = key.substr(1, key.size() - 2);
    for (const auto& [k, v] : node.map)
      if (k == key) throw std::runtime_error(where + ": the key '" + key + "' appears twice");
    const std::string rest = trim(line.text.substr(colon + 1));
    ++at;
    if (!rest.empty()) {
      node.map.emplace_back(key, FlowParser(rest, where).parse(line.number));
    } else if (at < lines.size() && lines[at].indent > indent) {
      node.map.emplace_back(key, block(lines, at, lines[at].indent, source));
    } else {
      throw std::runtime_error(where + ": the key '" + key + "' has no value");
    }
  }
  if (at < lines.size() && lines[at].indent > indent)
    throw std::runtime_error(source + ":" + std::to_string(lines[at].number) +
                             ": unexpected indentation");
  return node;
}

}  // namespace

const YamlNode* YamlNode::find(const std::string& key) const {
  for (const auto& [k, v] : map)
    if (k == key) return &v;
  return nullptr;
}

YamlNode parseYaml(const std::string& text, const std::string& source) {
  std::vector<Line> lines;
  int number = 0;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++number;
    const std::string raw = text.substr(start, end - start);
    start = end + 1;
    if (raw.find('\t') != std::string::npos && trim(raw).size() &&
        raw.find_first_not_of(" ") < raw.size() && raw[raw.find_first_not_of(" ")] == '\t')
      throw std::runtime_error(source + ":" + std::to_string(number) + ": tab indentation");
    const std::string content = trim(stripComment(raw));
    if (content.empty() || content == "---") continue;
    const int indent = static_cast<int>(raw.find_first_not_of(' '));
    lines.push_back({number, indent, content});
  }
  size_t at = 0;
  if (lines.empty()) return YamlNode{YamlNode::Kind::kMapping, "", {}, {}, 1};
  YamlNode root = block(lines, at, lines[0].indent, source);
  if (at != lines.size())
    throw std::runtime_error(source + ":" + std::to_string(lines[at].number) +
                             ": unexpected indentation");
  return root;
}

}  // namespace collision_response::calibration
