// SPDX-License-Identifier: MIT
#include "builder_spec.hpp"

#include "spacebvh/presets.hpp"
#include "spacebvh/settings.hpp"

namespace spacebvh::cli {

BuilderSpec parse_builder_spec(const std::string& text, const BuildCliOptions& defaults) {
    const size_t at = text.find('@');
    BuilderSpec spec{text, defaults.options(text.substr(0, at))};
    if (at != std::string::npos) {
        for (const std::string& item : CLI::detail::split(text.substr(at + 1), ';')) {
            const size_t equals = item.find('=');
            if (equals == std::string::npos) throw Error("builder '" + text + "': expected key=value after '@'");
            const std::string key = item.substr(0, equals), value = item.substr(equals + 1);
            const BuildSetting* setting = find_build_setting(key, SettingSpelling::row_key);
            if (!setting)
                throw Error("builder '" + text + "': unknown setting '" + key + "' (" +
                            known_settings(SettingSpelling::row_key) + ")");
            set_setting(spec.options, *setting, parse_setting(*setting, value, key));
        }
        spec.options.validate();
    }
    spec.label = spec.options.builder + (spec.options.reinsertion.iterations > 0 ? "+opt" : "") +
                 (at == std::string::npos ? "" : text.substr(at));
    return spec;
}

}  // namespace spacebvh::cli
