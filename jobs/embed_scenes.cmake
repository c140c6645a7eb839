# Generates a C++ source holding every studies/scenes/*.toml as text, so the program carries its
# default scenes (README main job, `softhom demo`) and runs without the source tree.
file(GLOB scene_files ${SCENE_DIR}/*.toml)
list(SORT scene_files)
set(body "")
foreach(f ${scene_files})
  get_filename_component(name ${f} NAME_WE)
  file(READ ${f} text)
  string(APPEND body "    {\"${name}\", R\"softhom_scene(${text})softhom_scene\"},\n")
endforeach()
file(WRITE ${OUTPUT}.tmp "// Generated from studies/scenes/*.toml by jobs/embed_scenes.cmake. Do not edit.\n#include \"embedded_scenes.hpp\"\nnamespace softhom::jobs {\nconst std::map<std::string, std::string>& embedded_scenes() {\n  static const std::map<std::string, std::string> scenes{\n${body}  };\n  return scenes;\n}\n}  // namespace softhom::jobs\n")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different ${OUTPUT}.tmp ${OUTPUT})
