#include "plugin_meta.hpp"

#include <elf.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <fstream>
#include <vector>

#include "varbo/errors.hpp"

namespace varbo::detail {

namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw PluginLoadError(fmt::format("{}: malformed plugin metadata ({} section): {}", path, VARBO_PLUGIN_META_SECTION, why));
}

bool terminated(const char* s, std::size_t n) { return std::memchr(s, '\0', n) != nullptr; }

// magic, struct_size, abi_version, api_version, reserved: the part every ABI keeps in place.
constexpr std::size_t kHeaderSize = offsetof(varbo_plugin_meta, name);

}  // namespace

bool PluginMeta::complete() const {
  const varbo_plugin_meta& m = block;
  return m.struct_size == sizeof(varbo_plugin_meta) && section_size >= sizeof(varbo_plugin_meta) &&
         terminated(m.name, sizeof m.name) && terminated(m.version, sizeof m.version) &&
         terminated(m.fingerprint, sizeof m.fingerprint) && terminated(m.description, sizeof m.description);
}

std::optional<PluginMeta> read_plugin_meta(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw PluginLoadError(fmt::format("{}: cannot open for reading: {}", path, std::strerror(errno)));
  in.seekg(0, std::ios::end);
  const auto file_size = static_cast<std::uint64_t>(in.tellg());
  auto read_at = [&](std::uint64_t offset, void* out, std::uint64_t size) {
    if (offset > file_size || size > file_size - offset) return false;
    in.seekg(static_cast<std::streamoff>(offset));
    in.read(static_cast<char*>(out), static_cast<std::streamsize>(size));
    return static_cast<std::uint64_t>(in.gcount()) == size;
  };
  Elf64_Ehdr eh{};
  if (!read_at(0, &eh, sizeof eh)) return std::nullopt;  // check_elf_file refused such files already
  if (eh.e_shoff == 0 || eh.e_shentsize != sizeof(Elf64_Shdr)) return std::nullopt;
  std::uint64_t shnum = eh.e_shnum;
  std::uint64_t shstrndx = eh.e_shstrndx;
  Elf64_Shdr first{};
  if (!read_at(eh.e_shoff, &first, sizeof first)) return std::nullopt;
  if (shnum == 0) shnum = first.sh_size;            // more than 0xff00 sections: the count is in section 0
  if (shstrndx == SHN_XINDEX) shstrndx = first.sh_link;
  if (shnum == 0 || shnum > file_size / sizeof(Elf64_Shdr) || shstrndx >= shnum) return std::nullopt;
  std::vector<Elf64_Shdr> sh(shnum);
  if (!read_at(eh.e_shoff, sh.data(), shnum * sizeof(Elf64_Shdr))) return std::nullopt;
  const Elf64_Shdr& names = sh[shstrndx];
  if (names.sh_type != SHT_STRTAB || names.sh_size > file_size) return std::nullopt;
  std::vector<char> strtab(names.sh_size + 1, '\0');
  if (!read_at(names.sh_offset, strtab.data(), names.sh_size)) return std::nullopt;

  for (const Elf64_Shdr& s : sh) {
    if (s.sh_name >= names.sh_size || std::strcmp(strtab.data() + s.sh_name, VARBO_PLUGIN_META_SECTION) != 0) continue;
    if (s.sh_type != SHT_PROGBITS) refuse(path, "not a data section");
    if (s.sh_size < kHeaderSize) refuse(path, fmt::format("{} bytes, smaller than its {}-byte header", s.sh_size, kHeaderSize));
    PluginMeta m;
    m.section_size = s.sh_size;
    const std::uint64_t n = std::min<std::uint64_t>(s.sh_size, sizeof m.block);
    if (!read_at(s.sh_offset, &m.block, n)) refuse(path, "it ends past the end of the file");
    if (std::memcmp(m.block.magic, VARBO_PLUGIN_META_MAGIC, sizeof VARBO_PLUGIN_META_MAGIC) != 0)
      refuse(path, "wrong magic bytes");
    return m;
  }
  return std::nullopt;
}

}  // namespace varbo::detail
