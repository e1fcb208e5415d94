#pragma once
// The JSON side of kfx's file formats (model files, error-ranges files, coupled model files): reading the
// file, its "format" and "version" fields, and one set of rules for the matrices and vectors written
// inline in it (docs/formats.md, "Matrices and vectors in JSON files"). Every error names the file and
// the field: "model.json: field 'Q': expected ..., got ...". Private to src/ (not installed).
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <string>

namespace kfx::detail {

using Json = nlohmann::json;

/// A field of a JSON file, for messages: "<file>: field '<name>': <context><what>".
struct JsonField {
  std::string file;     ///< path of the JSON file
  std::string name;     ///< the field's key
  std::string context;  ///< where in the field, e.g. "step 2: " (empty for the whole field)

  /// "<file>: field '<name>'".
  std::string Label() const;
  /// @throws kfx::Error "<file>: field '<name>': <context><what>".
  [[noreturn]] void Fail(const std::string& what) const;
};

/// What "got ..." shows of a JSON value: its type and its text, cut after 40 characters
/// ("string \"eye\"", "array [1,0]"; "null" for null).
std::string JsonBrief(const Json& v);

/// Reads `path` and parses it as a JSON object. `format` is the value its "format" field should hold
/// (for the message when the file holds no object). @throws kfx::Error "<path>: ..." when the path is a
/// directory, cannot be opened or read, is empty (white space only), is not JSON, or not an object.
Json ReadJsonObject(const std::string& path, const std::string& format);

/// Checks the "format" field of a file's object: when present it must be the string `format`;
/// `required`: it must be present. @throws kfx::Error naming the file and the field.
void CheckJsonFormat(const Json& root, const std::string& path, const std::string& format, bool required);
/// Checks the optional "version" field: a number equal to `version`. @throws kfx::Error naming the file.
void CheckJsonVersion(const Json& root, const std::string& path, int version);

/// The field `key` of `root` as an integer >= min. @throws kfx::Error naming the file and the field
/// when it is missing, not an integer, or smaller.
Eigen::Index JsonIndex(const Json& root, const std::string& path, const std::string& key, Eigen::Index min);

/// How deep lists nest, following first elements: 0 for a number, 1 for [1, 2] and for [], 2 for
/// [[1, 2]], 3 for [[[1]]]. Counts at most 9.
int JsonListDepth(const Json& v);

/// A matrix: a number (1 x 1) or a non-empty list of rows, each a non-empty list of finite numbers, all
/// rows of the same length. Anything else is an error naming the row and column at fault: a flat list
/// or an empty list, lists nested deeper than two, ragged rows, a non-number, a non-finite number.
/// @throws kfx::Error "<file>: field '<name>': <context>expected ..., got ...".
Eigen::MatrixXd JsonMatrix(const Json& v, const JsonField& field);
/// As JsonMatrix, and of shape rows x cols. An empty list [] is accepted when (and only when) that shape
/// has no entries. @throws kfx::Error as JsonMatrix, or "expected a RxC matrix, got R'xC'".
Eigen::MatrixXd JsonMatrix(const Json& v, const JsonField& field, Eigen::Index rows, Eigen::Index cols);

/// A vector: a number (length 1), a non-empty list of finite numbers, or a column written as a list of
/// one-number rows ([[1], [2]]). @throws kfx::Error as JsonMatrix, naming the entry at fault.
Eigen::VectorXd JsonVector(const Json& v, const JsonField& field);

/// The file named by a reference {"npy": "file.npy"}: relative to the directory of the JSON file unless
/// absolute. @throws kfx::Error naming the field if `v` is not such a reference.
std::string JsonNpyReference(const Json& v, const JsonField& field);

}  // namespace kfx::detail
