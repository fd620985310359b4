#include "igtlink/igtl_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <igtlPolyDataMessage.h>
#include <igtlStatusMessage.h>
#include <igtlTimeStamp.h>
#include <igtlTransformMessage.h>

namespace organsim::igtlink {

struct IgtlServer::Client {
  int fd = -1;
  std::string address;  // "ip:port"
  MessageReader reader;
  std::vector<std::uint8_t> outgoing;  // the frame being sent
  std::size_t sent = 0;
  std::size_t forces_at = 0;  // where `outgoing`'s forces begin (they end it)
  bool needs_surface = true;
  bool busy() const { return sent < outgoing.size(); }
};

struct IgtlServer::Messages {
  igtl::PolyDataMessage::Pointer surface = igtl::PolyDataMessage::New();
  igtl::PolyDataPointArray::Pointer points = igtl::PolyDataPointArray::New();
  std::vector<igtl::TransformMessage::Pointer> forces;
  igtl::TimeStamp::Pointer clock = igtl::TimeStamp::New();
  std::vector<std::uint8_t> surface_bytes, force_bytes;

  static void append(const igtl::MessageBase::Pointer& message, std::vector<std::uint8_t>& bytes) {
    const auto* begin = static_cast<const std::uint8_t*>(message->GetPackPointer());
    bytes.insert(bytes.end(), begin, begin + message->GetPackSize());
  }
};

// Turns the messages a client's stream completes into tool poses.
class IgtlServer::PoseHandler final : public MessageReader::Handler {
 public:
  PoseHandler(IgtlServer& server, Client& client) : server_(server), client_(client) {}

  void transform(const TransformMessage& message) override {
    const std::size_t tool = tool_index(message.info.device.data());
    if (tool == 0 || tool > server_.tools_.size()) return dropped(Problem::unknown_device, message.info);
    const auto& m = message.matrix;
    const double flip = server_.options_.ras ? -1.0 : 1.0;  // RAS ↔ LPS: x and y change sign
    devices::ToolPose pose;
    pose.tip = Eigen::Vector3d(flip * m[9], flip * m[10], m[11]) * 1e-3;
    if (!server_.reach_.contains(pose.tip)) return dropped(Problem::too_far, message.info);
    const Eigen::Vector3d shaft(flip * m[6], flip * m[7], m[8]);
    if (server_.options_.shaft_from_rotation && shaft.norm() > 1e-6) pose.shaft = shaft.normalized();
    pose.jaws_closed = server_.jaws_closed_[tool - 1];
    server_.tools_[tool - 1]->place(pose);
    server_.last_pose_[tool - 1] = pose;
    server_.last_poser_[tool - 1] = &client_;
    ++server_.counters_.poses;
  }
  // A grasper's jaws: from now on, with the tool's last pose if it has one.
  void jaws(const JawsMessage& message) override {
    const std::size_t tool = tool_index(message.info.device.data());
    if (tool == 0 || tool > server_.tools_.size()) return dropped(Problem::unknown_device, message.info);
    server_.jaws_closed_[tool - 1] = message.closed;
    if (server_.last_poser_[tool - 1] != nullptr) {
      server_.last_pose_[tool - 1].jaws_closed = message.closed;
      server_.tools_[tool - 1]->place(server_.last_pose_[tool - 1]);
    }
    ++server_.counters_.jaw_changes;
  }
  void dropped(Problem problem, const MessageInfo& info) override { server_.dropped(problem, info, client_); }

 private:
  // "toolK" → K (1 … 99), else 0.
  static std::size_t tool_index(const char* name) {
    if (std::strncmp(name, "tool", 4) != 0) return 0;
    std::size_t k = 0, digits = 0;
    for (const char* c = name + 4; *c != '\0'; ++c, ++digits) {
      if (*c < '0' || *c > '9' || digits == 2) return 0;
      k = 10 * k + static_cast<std::size_t>(*c - '0');
    }
    return digits > 0 && name[4] != '0' ? k : 0;
  }
  IgtlServer& server_;
  Client& client_;
};

IgtlServer::IgtlServer(const ServerOptions& options, const organ::Organ& organ,
                       std::vector<model::Triangle> file_triangles, std::vector<devices::StreamedTool*> tools,
                       lockfree::TripleBuffer<realtime::SurfaceFrame>& surfaces, Log warn, Log note)
    : options_(options),
      organ_(organ),
      file_triangles_(std::move(file_triangles)),
      tools_(std::move(tools)),
      surfaces_(surfaces),
      warn_(std::move(warn)),
      note_(std::move(note)),
      messages_(std::make_unique<Messages>()),
      last_poser_(tools_.size(), nullptr),
      last_pose_(tools_.size()),
      jaws_closed_(tools_.size(), false) {
  for (const model::Point3& p : organ_.model().surface_vertices) reach_.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  reach_.min().array() -= 10.0;
  reach_.max().array() += 10.0;

  // The rest surface until the engine publishes a frame.
  const std::vector<model::Point3>& rest = organ_.model().surface_vertices;
  positions_.resize(rest.size());
  for (std::size_t v = 0; v < rest.size(); ++v) positions_[organ_.file_vertex_index()[v]] = rest[v];

  Messages& m = *messages_;
  m.points->SetNumberOfPoints(static_cast<int>(positions_.size()));
  igtl::PolyDataCellArray::Pointer polygons = igtl::PolyDataCellArray::New();
  for (const model::Triangle& t : file_triangles_) {
    igtlUint32 corners[3] = {t[0], t[1], t[2]};
    polygons->AddCell(3, corners);
  }
  m.surface->SetDeviceName("organ");
  m.surface->SetPoints(m.points);
  m.surface->SetPolygons(polygons);
  for (std::size_t k = 0; k < tools_.size(); ++k) {
    m.forces.push_back(igtl::TransformMessage::New());
    m.forces.back()->SetDeviceName(fmt::format("tool{}_force", k + 1).c_str());
  }

  if (!(options_.force_period > 0.0 && options_.force_period <= options_.frame_period))
    throw std::invalid_argument(fmt::format("the forces' rate ({:g} Hz) must be at least the frame rate ({:g} Hz)",
                                            1.0 / options_.force_period, 1.0 / options_.frame_period));
  if (!(options_.force_tick_period > 0.0)) throw std::invalid_argument("the force loop's period must be positive");
  ticks_per_force_send_ =
      static_cast<std::uint64_t>(std::max(1.0, std::floor(options_.force_period / options_.force_tick_period + 1e-9)));
  in_addr address{};
  if (::inet_pton(AF_INET, options_.bind_address.c_str(), &address) != 1)
    throw std::invalid_argument(
        fmt::format("'{}' is not an IPv4 address (127.0.0.1 serves this machine only, 0.0.0.0 "
                    "every network it is on)",
                    options_.bind_address));
  listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listener_ < 0) throw std::runtime_error(fmt::format("cannot open a socket: {}", std::strerror(errno)));
  const int yes = 1;
  ::setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  sockaddr_in where{};
  where.sin_family = AF_INET;
  where.sin_addr = address;
  where.sin_port = htons(static_cast<std::uint16_t>(options_.port));
  if (::bind(listener_, reinterpret_cast<const sockaddr*>(&where), sizeof where) != 0 ||
      ::listen(listener_, SOMAXCONN) != 0) {
    const int error = errno;
    ::close(listener_);
    throw std::runtime_error(fmt::format("cannot listen on {}:{}: {}{}", options_.bind_address, options_.port,
                                         std::strerror(error),
                                         error == EADDRINUSE ? "; another program (another organsim serve, or a "
                                                               "Slicer server connector) has the port: pick another "
                                                               "with --igtl-port"
                                                             : ""));
  }
  socklen_t length = sizeof where;
  ::getsockname(listener_, reinterpret_cast<sockaddr*>(&where), &length);
  port_ = ntohs(where.sin_port);
}

IgtlServer::~IgtlServer() {
  for (const auto& client : clients_) ::close(client->fd);
  if (listener_ >= 0) ::close(listener_);
}

void IgtlServer::step(double now) {
  accept_clients();
  read_clients();
  for (std::size_t i = 0; i < clients_.size();) {
    if (!write_to(*clients_[i]))
      close(i, fmt::format("sending failed: {}", std::strerror(errno)));
    else
      ++i;
  }
  if (now >= next_frame_) {
    send_frame();
    next_frame_ = std::max(next_frame_ + options_.frame_period, now);
  } else if (options_.force_period < options_.frame_period && forces_due()) {
    send_forces();
  }
}

bool IgtlServer::forces_due() const {
  return !tools_.empty() && tools_.front()->ticks() - forces_packed_at_tick_ >= ticks_per_force_send_;
}

void IgtlServer::read_clients() {
  for (std::size_t i = 0; i < clients_.size();) {
    const Reading reading = read_from(*clients_[i]);
    if (reading != Reading::open)
      close(i, reading == Reading::closed_by_client ? "it closed the connection" : "the stream was out of step");
    else
      ++i;
  }
}

void IgtlServer::send_forces() {
  if (clients_.empty()) return;
  messages_->clock->GetTime();
  pack_forces();
  const Messages& m = *messages_;
  for (std::size_t i = 0; i < clients_.size();) {
    Client& client = *clients_[i];
    if (client.busy()) {
      // Still sending a frame: forces it has not begun to send are brought up
      // to date, so that they follow the surface as soon as it has gone;
      // forces now behind them would only queue up.
      if (client.sent <= client.forces_at && client.outgoing.size() - client.forces_at == m.force_bytes.size())
        std::copy(m.force_bytes.begin(), m.force_bytes.end(),
                  client.outgoing.begin() + static_cast<std::ptrdiff_t>(client.forces_at));
      ++i;
      continue;
    }
    client.outgoing.assign(m.force_bytes.begin(), m.force_bytes.end());
    client.sent = 0;
    client.forces_at = 0;
    ++counters_.force_updates;
    if (!write_to(client))
      close(i, fmt::format("sending failed: {}", std::strerror(errno)));
    else
      ++i;
  }
}

void IgtlServer::accept_clients() {
  // A flood of connections waits in the backlog rather than holding up one
  // step (and every client's forces) while it is drained.
  constexpr int kAcceptsPerStep = 16;
  bool accepted_since_reaping = true;  // clients of earlier steps may have gone too
  for (int accepted = 0; accepted < kAcceptsPerStep; ++accepted) {
    sockaddr_in peer{};
    socklen_t length = sizeof peer;
    const int fd = ::accept4(listener_, reinterpret_cast<sockaddr*>(&peer), &length, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // none waiting (EAGAIN), or the peer gave up before we got to it
    char ip[INET_ADDRSTRLEN] = "?";
    ::inet_ntop(AF_INET, &peer.sin_addr, ip, sizeof ip);
    const std::string address = fmt::format("{}:{}", ip, ntohs(peer.sin_port));
    // Clients that have gone free their place first: a client that
    // reconnects at once is not refused by its own old connection, nor one of
    // a burst by the connections before it in the same step that have closed.
    // Only when a client came since the last look: a flood of connections
    // while the clients stay costs one look a step.
    if (clients_.size() >= options_.max_clients && accepted_since_reaping) {
      read_clients();
      accepted_since_reaping = false;
    }
    if (clients_.size() >= options_.max_clients) {
      refuse(fd, fmt::format("organsim serve takes at most {} clients and all are connected; disconnect one and "
                             "connect again",
                             options_.max_clients));
      ++counters_.clients_refused;
      warn_(fmt::format("client {} refused: {} clients are connected already", address, clients_.size()));
      continue;
    }
    // Small force messages go out at once rather than waiting to fill a packet.
    const int yes = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
    auto client = std::make_unique<Client>();
    client->fd = fd;
    client->address = address;
    clients_.push_back(std::move(client));
    accepted_since_reaping = true;
    ++counters_.clients_accepted;
    note_(fmt::format("client {} connected", address));
  }
}

void IgtlServer::refuse(int fd, const std::string& why) {
  // The client learns why before the connection closes: a STATUS "busy"
  // (OpenIGTLink's answer for a device that cannot serve now) with the reason.
  // One small message into an empty socket buffer: the send does not block.
  igtl::StatusMessage::Pointer status = igtl::StatusMessage::New();
  status->SetDeviceName("organsim");
  status->SetCode(igtl::StatusMessage::STATUS_BUSY);
  status->SetErrorName("too many clients");
  status->SetStatusString(why.c_str());
  status->Pack();
  [[maybe_unused]] const ssize_t sent = ::send(fd, status->GetPackPointer(), status->GetPackSize(), MSG_NOSIGNAL);
  ::shutdown(fd, SHUT_WR);  // the STATUS, then an orderly end of the stream
  ::close(fd);
}

IgtlServer::Reading IgtlServer::read_from(Client& client) {
  std::uint8_t buffer[65536];
  PoseHandler handler(*this, client);
  // At most 1 MiB per step, so that one busy client cannot hold the others up.
  for (int reads = 0; reads < 16; ++reads) {
    const ssize_t n = ::recv(client.fd, buffer, sizeof buffer, 0);
    if (n > 0) {
      if (!client.reader.feed(buffer, static_cast<std::size_t>(n), handler)) return Reading::out_of_step;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) ? Reading::open : Reading::closed_by_client;
  }
  return Reading::open;
}

bool IgtlServer::write_to(Client& client) {
  while (client.busy()) {
    const ssize_t n =
        ::send(client.fd, client.outgoing.data() + client.sent, client.outgoing.size() - client.sent, MSG_NOSIGNAL);
    if (n > 0) {
      client.sent += static_cast<std::size_t>(n);
      counters_.bytes_sent += static_cast<std::uint64_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
  }
  return true;
}

void IgtlServer::close(std::size_t index, const std::string& why) {
  const Client* client = clients_[index].get();
  std::string lost;
  for (std::size_t k = 0; k < tools_.size(); ++k)
    if (last_poser_[k] == client) {
      tools_[k]->remove();
      last_poser_[k] = nullptr;
      jaws_closed_[k] = false;  // the hand that held the jaws is gone
      lost += fmt::format("{}{}", lost.empty() ? "" : ", ", k + 1);
    }
  note_(fmt::format(
      "client {} disconnected ({}){}", client->address, why,
      lost.empty() ? std::string() : fmt::format("; tool(s) {} lost their pose and their force fades to zero", lost)));
  ::close(client->fd);
  clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(index));
}

void IgtlServer::dropped(Problem problem, const MessageInfo& info, const Client& client) {
  const auto kind = static_cast<std::size_t>(problem);
  ++counters_.dropped[kind];
  if (logged_[kind]) return;
  logged_[kind] = true;
  warn_(fmt::format("client {}: a {} message named '{}' {}; {}", client.address, info.type.data(), info.device.data(),
                    describe(problem),
                    problem == Problem::out_of_step
                        ? "closing the connection (the client may connect again)"
                        : "dropped (further such messages are dropped without a word and counted)"));
}

void IgtlServer::send_frame() {
  if (surfaces_.update()) {
    const realtime::SurfaceFrame& frame = surfaces_.read();
    if (frame_observer_) frame_observer_(frame);
    const std::vector<std::uint32_t>& to_file = organ_.file_vertex_index();
    for (std::size_t v = 0; v < frame.positions.size() && v < positions_.size(); ++v) {
      model::Point3& slot = positions_[to_file[v]];
      if (slot != frame.positions[v]) {
        slot = frame.positions[v];
        surface_changed_ = true;
      }
    }
  }
  if (clients_.empty()) return;
  Messages& m = *messages_;
  m.clock->GetTime();  // the messages' time stamps: the wall clock now
  if (surface_changed_ || m.surface_bytes.empty()) pack_surface(positions_);
  pack_forces();
  for (std::size_t i = 0; i < clients_.size();) {
    Client& client = *clients_[i];
    if (client.busy()) {
      ++counters_.frames_missed;
      client.needs_surface = client.needs_surface || surface_changed_;
      ++i;
      continue;
    }
    client.outgoing.clear();
    client.sent = 0;
    if (surface_changed_ || client.needs_surface) {
      client.outgoing.insert(client.outgoing.end(), m.surface_bytes.begin(), m.surface_bytes.end());
      client.needs_surface = false;
      ++counters_.surfaces;
    }
    client.forces_at = client.outgoing.size();
    client.outgoing.insert(client.outgoing.end(), m.force_bytes.begin(), m.force_bytes.end());
    ++counters_.frames;
    if (!write_to(client))
      close(i, fmt::format("sending failed: {}", std::strerror(errno)));
    else
      ++i;
  }
  surface_changed_ = false;
}

void IgtlServer::pack_surface(const std::vector<model::Point3>& positions) {
  Messages& m = *messages_;
  const double flip = options_.ras ? -1.0 : 1.0;
  for (std::size_t v = 0; v < positions.size(); ++v)
    m.points->SetPoint(static_cast<unsigned int>(v), static_cast<igtlFloat32>(flip * positions[v][0] * 1e3),
                       static_cast<igtlFloat32>(flip * positions[v][1] * 1e3),
                       static_cast<igtlFloat32>(positions[v][2] * 1e3));
  m.surface->SetTimeStamp(m.clock);
  m.surface->Pack();
  m.surface_bytes.clear();
  Messages::append(igtl::MessageBase::Pointer(m.surface.GetPointer()), m.surface_bytes);
}

void IgtlServer::pack_forces() {
  // The count before the forces: each force read after it is at least that
  // tick's. Read after them, a tick that came while a frame was packed
  // would count as sent without its force, which then waited a tick more.
  if (!tools_.empty()) forces_packed_at_tick_ = tools_.front()->ticks();
  Messages& m = *messages_;
  const double flip = options_.ras ? -1.0 : 1.0;
  m.force_bytes.clear();
  for (std::size_t k = 0; k < tools_.size(); ++k) {
    bool in_contact = false;
    const Eigen::Vector3d force = tools_[k]->last_force(in_contact);
    igtl::Matrix4x4 matrix;
    igtl::IdentityMatrix(matrix);
    matrix[0][3] = static_cast<float>(flip * force[0]);
    matrix[1][3] = static_cast<float>(flip * force[1]);
    matrix[2][3] = static_cast<float>(force[2]);
    m.forces[k]->SetMatrix(matrix);
    m.forces[k]->SetTimeStamp(m.clock);
    m.forces[k]->Pack();
    Messages::append(igtl::MessageBase::Pointer(m.forces[k].GetPointer()), m.force_bytes);
  }
}

}  // namespace organsim::igtlink
