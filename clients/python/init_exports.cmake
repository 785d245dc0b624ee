# cmake -DINIT=.../coopdyn/__init__.py -P init_exports.cmake: appends to lcm-gen's __init__.py the line
# that re-exports the compiled bindings, once.
file(READ ${INIT} text)
string(FIND "${text}" "coopdyn._core" at)
if(at EQUAL -1)
  file(APPEND ${INIT} "\n# the compiled bindings (clients/python/module): load_scene, Scene, Evaluation, SceneError\nfrom coopdyn._core import *  # noqa: E402,F401,F403\n")
endif()
