// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/zaber/serial_line.h"

#include <fcntl.h>
#include <libserialport.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::zaber {
namespace {

int Milliseconds(absl::Duration d) {
  return static_cast<int>(
      std::clamp<int64_t>(absl::ToInt64Milliseconds(d), 1, 1 << 30));
}

class LibserialportLine final : public SerialLine {
 public:
  LibserialportLine(sp_port* port, std::string name)
      : port_(port), name_(std::move(name)) {}
  ~LibserialportLine() override {
    sp_close(port_);
    sp_free_port(port_);
  }

  absl::Status Write(absl::string_view data, absl::Duration timeout) override {
    sp_return n = sp_blocking_write(port_, data.data(), data.size(),
                                    Milliseconds(timeout));
    if (n < 0) return Error("cannot write to");
    if (static_cast<size_t>(n) != data.size()) {
      return absl::DeadlineExceededError(
          absl::StrCat("write to ", name_, " timed out"));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<std::string> Read(absl::Duration timeout) override {
    char buffer[256];
    sp_return n = sp_blocking_read_next(port_, buffer, sizeof buffer,
                                        Milliseconds(timeout));
    if (n < 0) return Error("cannot read from");
    return std::string(buffer, static_cast<size_t>(n));
  }

  void DiscardInput() override { sp_flush(port_, SP_BUF_INPUT); }

  absl::Status Error(absl::string_view what) const {
    char* message = sp_last_error_message();
    absl::Status status = absl::UnavailableError(
        absl::StrCat(what, " ", name_, ": ", message ? message : "unknown"));
    sp_free_error_message(message);
    return status;
  }

 private:
  sp_port* port_;
  std::string name_;
};

class TermiosLine final : public SerialLine {
 public:
  TermiosLine(int fd, std::string name) : fd_(fd), name_(std::move(name)) {}
  ~TermiosLine() override { ::close(fd_); }

  absl::Status Write(absl::string_view data, absl::Duration timeout) override {
    const absl::Time deadline = absl::Now() + timeout;
    while (!data.empty()) {
      pollfd p{fd_, POLLOUT, 0};
      int ready = ::poll(&p, 1, Milliseconds(deadline - absl::Now()));
      if (ready < 0 && errno == EINTR) continue;
      if (ready < 0) return Errno("cannot write to");
      if (ready == 0 || absl::Now() >= deadline) {
        return absl::DeadlineExceededError(
            absl::StrCat("write to ", name_, " timed out"));
      }
      ssize_t n = ::write(fd_, data.data(), data.size());
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (n < 0) return Errno("cannot write to");
      data.remove_prefix(static_cast<size_t>(n));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<std::string> Read(absl::Duration timeout) override {
    pollfd p{fd_, POLLIN, 0};
    int ready = ::poll(&p, 1, Milliseconds(timeout));
    if (ready < 0 && errno != EINTR) return Errno("cannot read from");
    if (ready <= 0) return std::string();
    char buffer[256];
    ssize_t n = ::read(fd_, buffer, sizeof buffer);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) return std::string();
    if (n < 0) return Errno("cannot read from");
    return std::string(buffer, static_cast<size_t>(n));
  }

  void DiscardInput() override { ::tcflush(fd_, TCIFLUSH); }

 private:
  absl::Status Errno(absl::string_view what) const {
    return absl::UnavailableError(
        absl::StrCat(what, " ", name_, ": ", std::strerror(errno)));
  }
  int fd_;
  std::string name_;
};

speed_t BaudConstant(int baud_rate) {
  switch (baud_rate) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    default:
      return B115200;
  }
}

absl::StatusOr<std::unique_ptr<SerialLine>> OpenTermios(const std::string& port,
                                                        int baud_rate) {
  int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    return absl::UnavailableError(absl::StrCat("cannot open serial port ", port,
                                               ": ", std::strerror(errno)));
  }
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) {
    const int err = errno;
    ::close(fd);
    return absl::UnavailableError(
        absl::StrCat(port, " is not a terminal: ", std::strerror(err)));
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);
  ::cfsetispeed(&tio, BaudConstant(baud_rate));
  ::cfsetospeed(&tio, BaudConstant(baud_rate));
  ::tcsetattr(fd, TCSANOW, &tio);
  ::tcflush(fd, TCIOFLUSH);
  return std::unique_ptr<SerialLine>(new TermiosLine(fd, port));
}

}  // namespace

absl::StatusOr<std::unique_ptr<SerialLine>> OpenSerialLine(
    const std::string& port, int baud_rate) {
  if (absl::StartsWith(port, "/dev/pts/")) return OpenTermios(port, baud_rate);
  sp_port* handle = nullptr;
  if (sp_get_port_by_name(port.c_str(), &handle) != SP_OK) {
    char* message = sp_last_error_message();
    absl::Status status = absl::UnavailableError(
        absl::StrCat("cannot find serial port ", port, ": ",
                     message ? message : "unknown error"));
    sp_free_error_message(message);
    return status;
  }
  auto line = std::make_unique<LibserialportLine>(handle, port);
  if (sp_open(handle, SP_MODE_READ_WRITE) != SP_OK) {
    return line->Error("cannot open serial port");
  }
  if (sp_set_baudrate(handle, baud_rate) != SP_OK ||
      sp_set_bits(handle, 8) != SP_OK ||
      sp_set_parity(handle, SP_PARITY_NONE) != SP_OK ||
      sp_set_stopbits(handle, 1) != SP_OK ||
      sp_set_flowcontrol(handle, SP_FLOWCONTROL_NONE) != SP_OK) {
    return line->Error("cannot configure serial port");
  }
  sp_flush(handle, SP_BUF_BOTH);
  return line;
}

}  // namespace hdrstereo::zaber
