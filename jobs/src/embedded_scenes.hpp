#pragma once
// The generated source of jobs::embedded_scenes() (embed_scenes.cmake); declared in scene.hpp.
#include "softhom/jobs/scene.hpp"
