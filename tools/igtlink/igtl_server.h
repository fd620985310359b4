// The OpenIGTLink side of `organsim serve`: a TCP server that takes tool poses
// from clients (3D Slicer, PLUS, a robot controller) and sends the deformed
// organ and the tools' forces back.
//
// In: TRANSFORM messages named tool1 … toolN. The translation is the tool's tip
// (mm), the rotation's third column its shaft direction (from the tip towards
// the handle), in the model's frame (LPS) or, with `ras`, in 3D Slicer's RAS
// frame. Each pose goes to its tool (a StreamedTool the engine's force loop
// reads, wait-free).
// Out, every frame period: POLYDATA `organ` (the deformed surface, mm, the model
// file's vertex order and triangles; sent when it changed, and to each client
// once when it connects) and TRANSFORM `toolK_force` for every tool (identity
// rotation, translation = the force on the tool in N).
//
// Protocol version 1 headers are sent; version 1 and 2 headers are read. A bad
// message (MessageReader's Problem) is dropped, logged the first time its kind
// occurs and counted; a stream that is out of step is closed. A client that
// disconnects takes its tools' poses with it (their forces fade to zero) and may
// connect again. A client that reads slower than frames come misses frames
// (counted) instead of making the server buffer them: memory stays one frame
// per client whatever the clients do. A client beyond max_clients gets a STATUS
// message (code 6, busy) saying why, and is closed.
//
// step() never blocks: the sockets are non-blocking and polled from the
// caller's thread (run_realtime's poll: every 2 ms, or a quarter of the force
// period when forces go faster than frames). The library's own socket
// classes block with timeouts, so the server uses POSIX sockets for the
// transport and libOpenIGTLink for the messages.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "igtlink/message_reader.h"
#include "organsim/devices/streamed_tool.h"
#include "organsim/model/organ_model.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"

namespace organsim::igtlink {

struct ServerOptions {
  std::string bind_address = "127.0.0.1";  ///< "0.0.0.0" serves other machines
  int port = 18944;                        ///< OpenIGTLink's usual port; 0 picks a free one
  double frame_period = 1.0 / 60.0;        ///< s between frames sent (the surface when it changed, and the forces)
  /// s between the tools' forces sent: at most frame_period; shorter for
  /// robots and haptic clients (1e-3: 1 kHz). The caller must step() at least
  /// this often.
  double force_period = 1.0 / 60.0;
  /// s between the engine's force ticks: forces leave right after the tick
  /// that computed them, every force_period / force_tick_period ticks rounded
  /// down (never slower than asked: 400 Hz sends every 2 ticks of 1 ms), so
  /// that a pose's force waits for no clock of the server's own.
  double force_tick_period = 1e-3;
  bool ras = false;                 ///< clients use RAS (3D Slicer): x and y change sign at the boundary
  bool shaft_from_rotation = true;  ///< false: poses give the tip only
  std::size_t max_clients = 8;
};

struct ServerCounters {
  std::uint64_t clients_accepted = 0;
  std::uint64_t clients_refused = 0;  ///< beyond max_clients
  std::uint64_t poses = 0;            ///< TRANSFORM messages that moved a tool
  std::uint64_t jaw_changes = 0;      ///< STRING messages that opened or closed a tool's jaws
  std::uint64_t frames = 0;           ///< frames sent (forces, and the surface when it changed)
  std::uint64_t surfaces = 0;         ///< POLYDATA messages sent
  std::uint64_t frames_missed = 0;    ///< frames a slow client was still busy with the previous one for
  std::uint64_t force_updates = 0;    ///< force-only sends between frames (--force-rate), summed over clients
  std::uint64_t bytes_sent = 0;
  std::array<std::uint64_t, kProblemKinds> dropped{};  ///< messages dropped, by Problem
};

class IgtlServer {
 public:
  using Log = std::function<void(const std::string&)>;

  /// Listens on options.bind_address:port. `tools` are the engine's devices
  /// (tool K is tools[K-1]); `surfaces` is the engine's surface hand-off, which
  /// the server reads (its only reader); `file_triangles` are the model file's.
  /// `warn` receives bad messages (once per kind) and failures, `note` clients
  /// coming and going. Throws std::runtime_error when it cannot listen.
  IgtlServer(const ServerOptions& options, const organ::Organ& organ, std::vector<model::Triangle> file_triangles,
             std::vector<devices::StreamedTool*> tools, lockfree::TripleBuffer<realtime::SurfaceFrame>& surfaces,
             Log warn, Log note);
  ~IgtlServer();
  IgtlServer(const IgtlServer&) = delete;
  IgtlServer& operator=(const IgtlServer&) = delete;

  /// The port it listens on (the one picked when options.port was 0).
  int port() const noexcept { return port_; }
  /// Accepts, reads and writes what is ready, sends a frame when one is due at
  /// `now` (s, any steady clock) and the forces when the force loop has
  /// computed new ones (--force-rate). Never blocks.
  void step(double now);
  const ServerCounters& counters() const noexcept { return counters_; }
  std::size_t clients() const noexcept { return clients_.size(); }
  /// Called with every new deformation frame the server reads (a training
  /// report's recorder, say), on step()'s thread.
  void observe_frames(std::function<void(const realtime::SurfaceFrame&)> observer) {
    frame_observer_ = std::move(observer);
  }

 private:
  struct Client;
  struct Messages;
  class PoseHandler;

  enum class Reading { open, closed_by_client, out_of_step };

  void accept_clients();
  /// Tells a client beyond max_clients why (a STATUS message) and closes it.
  void refuse(int fd, const std::string& why);
  /// Reads what every client sent; closes those that left or went out of step.
  void read_clients();
  Reading read_from(Client& client);
  bool write_to(Client& client);
  void close(std::size_t index, const std::string& why);
  std::function<void(const realtime::SurfaceFrame&)> frame_observer_;
  void send_frame();
  void pack_surface(const std::vector<model::Point3>& positions_in_file_order);
  void pack_forces();
  /// The tools' forces alone to every client not still busy with earlier bytes.
  void send_forces();
  void dropped(Problem problem, const MessageInfo& info, const Client& client);

  ServerOptions options_;
  const organ::Organ& organ_;
  std::vector<model::Triangle> file_triangles_;
  std::vector<devices::StreamedTool*> tools_;
  lockfree::TripleBuffer<realtime::SurfaceFrame>& surfaces_;
  Log warn_, note_;
  Eigen::AlignedBox3d reach_;  // m: the organ's box grown by 10 m
  int listener_ = -1;
  int port_ = 0;
  std::vector<std::unique_ptr<Client>> clients_;
  /// Whether the force loop has ticked often enough since the last forces sent.
  bool forces_due() const;
  double next_frame_ = 0.0;
  std::uint64_t ticks_per_force_send_ = 1;
  std::uint64_t forces_packed_at_tick_ = 0;  // the first tool's tick count when forces were last packed
  std::vector<model::Point3> positions_;     // m, file order: the surface last packed
  bool surface_changed_ = true;
  std::unique_ptr<Messages> messages_;        // libOpenIGTLink's messages, packed in place each frame
  std::vector<const Client*> last_poser_;     // per tool: the client whose pose it holds, or null
  std::vector<devices::ToolPose> last_pose_;  // per tool: the pose it holds
  std::vector<bool> jaws_closed_;             // per tool: the jaws as the last STRING message left them
  std::array<bool, kProblemKinds> logged_{};
  ServerCounters counters_;
};

}  // namespace organsim::igtlink
