#!/usr/bin/env bash
# Makes sure what checks and runs `generate --target` output is installed:
# glslang (glslangValidator: GLSL, GLSL ES, and HLSL through its HLSL front
# end), spirv-tools (spirv-val, spirv-dis), and Mesa's EGL and OpenGL driver
# (libEGL_mesa, llvmpipe), on which `verify --target glsl --backend gl` runs
# the emitted GLSL text. Installs them with apt when running as root;
# otherwise prints the exact command and fails.
# Source it (scripts/test.sh and scripts/demo.sh do).
boxforge_packages="glslang-tools spirv-tools libegl1 libegl-mesa0 libgl1-mesa-dri"
have_egl_mesa() {
    { ldconfig -p 2>/dev/null | grep 'libEGL_mesa.so.0' >/dev/null; } || ls /usr/lib/*/libEGL_mesa.so.0 >/dev/null 2>&1
}
if ! command -v glslangValidator >/dev/null || ! command -v spirv-val >/dev/null || ! have_egl_mesa; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "Installing the shader compilers and Mesa's EGL driver with apt-get ($boxforge_packages)..." >&2
        # shellcheck disable=SC2086
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $boxforge_packages >/dev/null
    else
        echo "error: glslangValidator, spirv-val and Mesa's EGL are needed to check and run the translated shaders. Install them, e.g.: sudo apt-get install -y $boxforge_packages" >&2
        exit 2
    fi
fi
