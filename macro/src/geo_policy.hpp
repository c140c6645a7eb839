#pragma once
// What a Gmsh .geo file of a scene may do: describe geometry and meshing. Gmsh's language also runs
// shell commands (System, SystemCall, NonBlockingSystemCall, OnelabRun), writes files (Save, Print,
// Printf(...) > "file", CreateDir, Delete/Rename of files, Plugin runs that export) and reads any file
// (Include, Merge, ShapeFromFile): a .geo is refused when it uses the first two kinds, and when it reads a
// file outside its own folder (an absolute path, "..", or a name built from expressions the check
// cannot read). Comments and string contents are not commands. Gmsh itself is run as a separate
// program on the checked text, so the check is what stands between a shared scene and the machine.
#include <filesystem>
#include <string>

namespace softhom::macro {

/// Throws InputError(field, "<geo>:<line>", why) at the first command outside the policy above.
void check_geo_text(const std::string& text, const std::filesystem::path& geo, const std::string& field);

}  // namespace softhom::macro
