# Sourced by scripts: point wgpu at Mesa's software Vulkan (lavapipe) when no
# other driver was chosen, so GPU code runs on machines without a GPU.
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -z "${VK_ICD_FILENAMES:-}" ]; then
  for f in /usr/share/vulkan/icd.d/lvp_icd.*.json; do
    [ -e "$f" ] && export VK_DRIVER_FILES="$f" && break
  done
fi
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
