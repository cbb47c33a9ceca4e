#!/usr/bin/env bash
# Makes sure the shader compilers that check `generate --target` are
# installed: glslang (glslangValidator: GLSL, GLSL ES, and HLSL through its
# HLSL front end) and spirv-tools (spirv-val, spirv-dis). Installs them with
# apt when running as root; otherwise prints the exact command and fails.
# Source it (scripts/test.sh and scripts/demo.sh do).
if ! command -v glslangValidator >/dev/null || ! command -v spirv-val >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "No glslangValidator or spirv-val found: installing glslang-tools and spirv-tools with apt-get..." >&2
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq glslang-tools spirv-tools >/dev/null
    else
        echo "error: glslangValidator and spirv-val are needed to check the translated shaders. Install them, e.g.: sudo apt-get install -y glslang-tools spirv-tools" >&2
        exit 2
    fi
fi
