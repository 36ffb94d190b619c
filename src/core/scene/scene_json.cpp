// The scene reader's JSON layer: values with their lines (scene_json.hpp).
#include "scene/scene_json.hpp"

#include <iterator>

namespace cutsim::core::detail {

namespace {

/// Input iterator over the text that counts the lines of the characters it has delivered.
struct LineCounter {
  std::size_t line = 1;
  char last = '\0';
};

class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, LineCounter* counter) : p_(p), counter_(counter) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    counter_->last = *p_;
    if (*p_ == '\n') ++counter_->line;
    ++p_;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& o) const { return p_ == o.p_; }
  bool operator!=(const CountingIterator& o) const { return p_ != o.p_; }

 private:
  const char* p_;
  LineCounter* counter_;
};

}  // namespace

std::string escapePointerToken(const std::string& key) {
  std::string out;
  for (char c : key) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

namespace {

/// Builds the DOM and records, for every value, the line where it ends (scalars) or starts
/// (objects, arrays), keyed by its JSON pointer.
class LineRecordingBuilder : public nlohmann::json_sax<json> {
 public:
  static constexpr std::size_t kMaxDepth = 64;

  LineRecordingBuilder(LineCounter& counter, std::string source)
      : counter_(counter), source_(std::move(source)) {}

  json root;
  std::map<std::string, std::size_t> lines;

  bool null() override { return put(json(nullptr), false); }
  bool boolean(bool b) override { return put(json(b), false); }
  bool number_integer(number_integer_t v) override { return put(json(v), true); }
  bool number_unsigned(number_unsigned_t v) override { return put(json(v), true); }
  bool number_float(number_float_t v, const string_t&) override { return put(json(v), true); }
  bool string(string_t& s) override { return put(json(s), false); }
  bool binary(binary_t&) override { return put(json(nullptr), false); }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    Frame& f = stack_.back();
    if (f.value->contains(k)) {
      duplicateKey_ = f.pointer + "/" + escapePointerToken(k);
      duplicateLine_ = counter_.line;
      return false;
    }
    f.key = k;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    std::string message = e.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error while
    // parsing value - invalid literal; last read: 'x'": keep what follows the position.
    // Other errors ("[json.exception.out_of_range.406] number overflow parsing '1e999'") have no
    // position: the bracketed tag goes.
    const std::size_t colon = message.find(": ");
    if (message.rfind("[json.exception.", 0) == 0 && colon != std::string::npos) {
      message = message.substr(colon + 2);
    } else if (message.rfind("[json.exception.", 0) == 0 &&
               message.find("] ") != std::string::npos) {
      message = message.substr(message.find("] ") + 2);
    }
    if (message.rfind("number overflow parsing", 0) == 0)
      message += " (beyond the range of doubles, about 1.8e308)";
    throw InvalidInput(source_ + ":" + std::to_string(counter_.line), "invalid JSON: " + message);
  }

  void throwIfDuplicate() const {
    if (!duplicateKey_.empty()) {
      throw InvalidInput(source_ + ":" + std::to_string(duplicateLine_),
                         duplicateKey_ + ": duplicate key");
    }
  }

 private:
  struct Frame {
    json* value;
    std::string pointer;
    std::string key;  // the pending key of an object
  };

  /// Pointer of the value about to be put into the innermost container (or the root).
  std::string childPointer() const {
    if (stack_.empty()) return "";
    const Frame& f = stack_.back();
    if (f.value->is_object()) return f.pointer + "/" + escapePointerToken(f.key);
    return f.pointer + "/" + std::to_string(f.value->size());
  }

  json* insert(json value) {
    if (stack_.empty()) {
      root = std::move(value);
      return &root;
    }
    Frame& f = stack_.back();
    if (f.value->is_object()) return &((*f.value)[f.key] = std::move(value));
    f.value->push_back(std::move(value));
    return &f.value->back();
  }

  std::size_t currentLine(bool lookahead) const {
    // A number is known only once the character after it was read; if that was a newline, the
    // number ended on the line before.
    if (lookahead && counter_.last == '\n' && counter_.line > 1) return counter_.line - 1;
    return counter_.line;
  }

  bool put(json value, bool lookahead) {
    lines[childPointer()] = currentLine(lookahead);
    insert(std::move(value));
    return true;
  }
  bool open(json container) {
    // A scene is a few levels deep; refusing deep nesting early keeps the pointer bookkeeping
    // (a string per level) from growing quadratically on a malicious or broken file.
    if (stack_.size() >= kMaxDepth) {
      throw InvalidInput(
          source_ + ":" + std::to_string(counter_.line),
          "invalid JSON: nested deeper than " + std::to_string(kMaxDepth) + " levels");
    }
    const std::string pointer = childPointer();
    lines[pointer] = counter_.line;
    json* inserted = insert(std::move(container));
    stack_.push_back({inserted, pointer, {}});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  LineCounter& counter_;
  std::string source_;
  std::vector<Frame> stack_;
  std::string duplicateKey_;
  std::size_t duplicateLine_ = 0;
};

}  // namespace

JsonDocument parseJsonWithLines(std::string_view text, const std::string& source) {
  LineCounter counter;
  LineRecordingBuilder builder(counter, source);
  const bool ok = json::sax_parse(CountingIterator(text.data(), &counter),
                                  CountingIterator(text.data() + text.size(), &counter), &builder);
  builder.throwIfDuplicate();
  if (!ok) throw InvalidInput(source, "invalid JSON");
  return {std::move(builder.root), std::move(builder.lines)};
}

}  // namespace cutsim::core::detail
