#include "elf_check.hpp"

#include <elf.h>
#include <fmt/format.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "varbo/errors.hpp"

namespace fs = std::filesystem;

namespace varbo::detail {

namespace {

#if defined(__x86_64__)
constexpr unsigned kHostMachine = EM_X86_64;
#elif defined(__aarch64__)
constexpr unsigned kHostMachine = EM_AARCH64;
#elif defined(__riscv) && __riscv_xlen == 64
constexpr unsigned kHostMachine = EM_RISCV;
#elif defined(__powerpc64__)
constexpr unsigned kHostMachine = EM_PPC64;
#elif defined(__s390x__)
constexpr unsigned kHostMachine = EM_S390;
#else
constexpr unsigned kHostMachine = EM_NONE;  // unknown host: the machine check is left to dlopen
#endif
static_assert(sizeof(void*) == 8, "varbo's plugin loader expects a 64-bit host (ELF64 plugins)");

#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
constexpr unsigned char kHostData = ELFDATA2LSB;
#else
constexpr unsigned char kHostData = ELFDATA2MSB;
#endif

std::string host_name() { return elf_machine_name(kHostMachine) + " (64-bit)"; }

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw PluginLoadError(fmt::format("{}: {}", path, why));
}

std::string file_kind(fs::file_type t) {
  switch (t) {
    case fs::file_type::directory: return "a directory";
    case fs::file_type::fifo: return "a named pipe (FIFO)";
    case fs::file_type::socket: return "a socket";
    case fs::file_type::block: return "a block device";
    case fs::file_type::character: return "a character device";
    default: return "not a regular file";
  }
}

/// offset + count * size <= file_size, without overflow.
bool fits(std::uint64_t offset, std::uint64_t count, std::uint64_t size, std::uint64_t file_size) {
  if (offset > file_size) return false;
  if (size != 0 && count > (file_size - offset) / size) return false;
  return true;
}

}  // namespace

std::string elf_machine_name(unsigned machine) {
  switch (machine) {
    case EM_X86_64: return "x86-64";
    case EM_386: return "i386";
    case EM_AARCH64: return "aarch64";
    case EM_ARM: return "arm";
    case EM_RISCV: return "riscv";
    case EM_PPC64: return "ppc64";
    case EM_PPC: return "ppc";
    case EM_S390: return "s390x";
    case EM_MIPS: return "mips";
    case EM_SPARCV9: return "sparc64";
    case EM_LOONGARCH: return "loongarch";
    case EM_NONE: return "no machine";
    default: return fmt::format("machine {}", machine);
  }
}

void check_elf_file(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);  // follows symlinks
  if (ec) {
    if (ec == std::errc::too_many_symbolic_link_levels) refuse(path, "symbolic link loop (" + ec.message() + ")");
    if (ec == std::errc::no_such_file_or_directory) {
      if (fs::is_symlink(fs::symlink_status(path, ec)))
        refuse(path, "broken symbolic link (its target does not exist)");
      refuse(path, "plugin library not found");
    }
    refuse(path, "cannot read: " + ec.message());
  }
  if (!fs::exists(st)) refuse(path, "plugin library not found");
  if (!fs::is_regular_file(st)) refuse(path, file_kind(st.type()) + ", not a shared library file");
  const std::uint64_t file_size = fs::file_size(path, ec);
  if (ec) refuse(path, "cannot read: " + ec.message());

  std::ifstream in(path, std::ios::binary);
  if (!in) refuse(path, "cannot open for reading: " + std::string(std::strerror(errno)));
  unsigned char ident[EI_NIDENT] = {};
  in.read(reinterpret_cast<char*>(ident), EI_NIDENT);
  if (in.gcount() < SELFMAG || std::memcmp(ident, ELFMAG, SELFMAG) != 0)
    refuse(path, "not a shared library (no ELF header)");
  if (in.gcount() < EI_NIDENT) refuse(path, fmt::format("truncated ELF header ({} bytes)", file_size));
  if (ident[EI_CLASS] != ELFCLASS64) {
    // The class decides the header layout; e_machine sits at the same offset (18) in both.
    unsigned char m[2] = {0, 0};
    in.seekg(18);
    in.read(reinterpret_cast<char*>(m), 2);
    const unsigned machine = ident[EI_DATA] == ELFDATA2MSB ? (m[0] << 8 | m[1]) : (m[1] << 8 | m[0]);
    const std::string bits = ident[EI_CLASS] == ELFCLASS32 ? "32-bit" : fmt::format("ELF class {}", ident[EI_CLASS]);
    refuse(path, fmt::format("built for {} ({}), this is {}; rebuild the plugin for this machine",
                             elf_machine_name(machine), bits, host_name()));
  }
  if (ident[EI_DATA] != kHostData)
    refuse(path, fmt::format("built for {} byte order, this host is {}-endian; rebuild the plugin for this machine",
                             ident[EI_DATA] == ELFDATA2MSB ? "big-endian" : "an unknown",
                             kHostData == ELFDATA2LSB ? "little" : "big"));

  Elf64_Ehdr eh{};
  in.seekg(0);
  in.read(reinterpret_cast<char*>(&eh), sizeof eh);
  if (static_cast<std::size_t>(in.gcount()) < sizeof eh)
    refuse(path, fmt::format("truncated ELF header ({} bytes, a 64-bit header has {})", file_size, sizeof eh));
  if (kHostMachine != EM_NONE && eh.e_machine != kHostMachine)
    refuse(path, fmt::format("built for {}, this is {}; rebuild the plugin for this machine",
                             elf_machine_name(eh.e_machine), host_name()));
  if (eh.e_type != ET_DYN)
    refuse(path, fmt::format("not a shared library (ELF type {}; build it as a MODULE or SHARED library)",
                             eh.e_type == ET_EXEC ? "executable" : eh.e_type == ET_REL ? "relocatable object"
                                                                 : eh.e_type == ET_CORE ? "core dump"
                                                                                         : std::to_string(eh.e_type)));

  const std::string truncated = fmt::format("truncated or corrupt shared library ({} bytes): ", file_size);
  if (eh.e_phnum == 0 || eh.e_phnum == PN_XNUM) refuse(path, truncated + "no program headers");
  if (eh.e_phentsize != sizeof(Elf64_Phdr))
    refuse(path, truncated + fmt::format("program header entry size {} (expected {})", eh.e_phentsize,
                                         sizeof(Elf64_Phdr)));
  if (!fits(eh.e_phoff, eh.e_phnum, sizeof(Elf64_Phdr), file_size))
    refuse(path, truncated + fmt::format("the program header table (offset {}, {} entries) ends past the end "
                                         "of the file",
                                         eh.e_phoff, eh.e_phnum));
  std::vector<Elf64_Phdr> ph(eh.e_phnum);
  in.seekg(static_cast<std::streamoff>(eh.e_phoff));
  in.read(reinterpret_cast<char*>(ph.data()), static_cast<std::streamsize>(ph.size() * sizeof(Elf64_Phdr)));
  if (!in) refuse(path, truncated + "cannot read the program headers");
  bool any_load = false;
  for (std::size_t i = 0; i < ph.size(); ++i) {
    const Elf64_Phdr& p = ph[i];
    if (p.p_type == PT_LOAD) {
      any_load = true;
      if (p.p_filesz > p.p_memsz)
        refuse(path, truncated + fmt::format("segment {} has more file bytes ({}) than memory bytes ({})", i,
                                             p.p_filesz, p.p_memsz));
    }
    if (p.p_type == PT_NULL || p.p_filesz == 0) continue;
    if (!fits(p.p_offset, 1, p.p_filesz, file_size))
      refuse(path, truncated + fmt::format("segment {} (offset {}, {} bytes) ends past the end of the file", i,
                                           p.p_offset, p.p_filesz));
  }
  if (!any_load) refuse(path, truncated + "no loadable segment");

  // dlopen does not read section headers, but a table past the end is the mark of a cut-off file.
  if (eh.e_shoff != 0) {
    if (eh.e_shentsize != sizeof(Elf64_Shdr))
      refuse(path, truncated + fmt::format("section header entry size {} (expected {})", eh.e_shentsize,
                                           sizeof(Elf64_Shdr)));
    std::uint64_t shnum = eh.e_shnum;
    if (!fits(eh.e_shoff, shnum == 0 ? 1 : shnum, sizeof(Elf64_Shdr), file_size))
      refuse(path, truncated + fmt::format("the section header table (offset {}, {} entries) ends past the end "
                                           "of the file",
                                           eh.e_shoff, shnum));
  }
}

}  // namespace varbo::detail
