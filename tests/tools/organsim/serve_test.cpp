// `organsim serve`: a libOpenIGTLink client on 127.0.0.1 presses a tool into
// the organ and gets back the deformed surface and `organsim poke`'s force;
// bad messages are logged once and dropped; a client that comes back is served.
#include <gtest/gtest.h>
#include <fstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <regex>
#include <thread>

#include <Eigen/Core>
#include <igtlClientSocket.h>
#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlStatusMessage.h>
#include <igtlTransformMessage.h>

#include "cli_fixture.h"
#include "igtl_messages.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;
using Clock = std::chrono::steady_clock;

// `organsim serve …` in the background, its output in files.
class ServeProcess {
 public:
  ServeProcess(const std::string& arguments, const fs::path& dir) : out_(dir / "serve.out"), err_(dir / "serve.err") {
    const std::string command =
        fmt::format("exec {} serve {} >{} 2>{}", ORGANSIM_EXECUTABLE, arguments, out_.string(), err_.string());
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  ~ServeProcess() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  ServeProcess(const ServeProcess&) = delete;
  ServeProcess& operator=(const ServeProcess&) = delete;

  /// The port it says it listens on (0 when it did not say within 30 s).
  int port() {
    const std::regex listening(R"(on 127\.0\.0\.1:(\d+))");
    for (auto until = Clock::now() + std::chrono::seconds(30); Clock::now() < until;) {
      std::smatch match;
      const std::string err = read_bytes(err_);
      if (std::regex_search(err, match, listening)) return std::stoi(match[1]);
      if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        ADD_FAILURE() << "serve ended early: " << err;
        return 0;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return 0;
  }
  std::string err() const { return read_bytes(err_); }
  /// SIGTERM, then what it printed and its exit code.
  CommandRun stop() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), read_bytes(out_), read_bytes(err_)};
  }

 private:
  fs::path out_, err_;
  pid_t pid_ = -1;
};

// What a client received: the last force of each tool, the last surface.
struct Received {
  std::map<std::string, Eigen::Vector3d> forces;
  std::vector<Eigen::Vector3d> surface;  // mm
  int surfaces = 0;
  int force_messages = 0;
};

class IgtlClient {
 public:
  explicit IgtlClient(int port) {
    connected_ = socket_->ConnectToServer("127.0.0.1", port) == 0;
    socket_->SetReceiveTimeout(1000);
  }
  bool connected() const { return connected_; }
  void send(const testing::Bytes& bytes) { ASSERT_NE(socket_->Send(bytes.data(), static_cast<int>(bytes.size())), 0); }
  void send_tip(const Eigen::Vector3d& tip_mm, const Eigen::Vector3d& shaft) {
    send(testing::transform_message("tool1", {tip_mm[0], tip_mm[1], tip_mm[2]}, {shaft[0], shaft[1], shaft[2]}));
  }
  /// Reads what the server sends for `seconds`.
  void receive_for(double seconds, Received& r) {
    for (auto until = Clock::now() + std::chrono::duration<double>(seconds); Clock::now() < until;) {
      igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
      header->InitPack();
      if (socket_->Receive(header->GetPackPointer(), header->GetPackSize()) != header->GetPackSize()) continue;
      header->Unpack();
      const std::string type = header->GetDeviceType();
      if (type == "TRANSFORM") {
        igtl::TransformMessage::Pointer message = igtl::TransformMessage::New();
        message->SetMessageHeader(header);
        message->AllocatePack();
        socket_->Receive(message->GetPackBodyPointer(), message->GetPackBodySize());
        ASSERT_TRUE(message->Unpack(1) & igtl::MessageHeader::UNPACK_BODY) << "CRC of " << header->GetDeviceName();
        igtl::Matrix4x4 m;
        message->GetMatrix(m);
        r.forces[header->GetDeviceName()] = Eigen::Vector3d(m[0][3], m[1][3], m[2][3]);
        ++r.force_messages;
      } else if (type == "POLYDATA") {
        igtl::PolyDataMessage::Pointer message = igtl::PolyDataMessage::New();
        message->SetMessageHeader(header);
        message->AllocatePack();
        socket_->Receive(message->GetPackBodyPointer(), message->GetPackBodySize());
        ASSERT_TRUE(message->Unpack(1) & igtl::MessageHeader::UNPACK_BODY);
        EXPECT_STREQ(header->GetDeviceName(), "organ");
        igtl::PolyDataPointArray::Pointer points = message->GetPoints();
        r.surface.resize(static_cast<std::size_t>(points->GetNumberOfPoints()));
        for (std::size_t v = 0; v < r.surface.size(); ++v) {
          igtlFloat32 p[3];
          points->GetPoint(static_cast<unsigned int>(v), p);
          r.surface[v] = Eigen::Vector3d(p[0], p[1], p[2]);
        }
        ++r.surfaces;
      } else {
        ADD_FAILURE() << "unexpected message type " << type;
        return;
      }
    }
  }
  void close() { socket_->CloseSocket(); }

 private:
  igtl::ClientSocket::Pointer socket_ = igtl::ClientSocket::New();
  bool connected_ = false;
};

TEST_F(Cli, ServePressedOverOpenIgtLinkSendsTheDeformedOrganAndPokesForce) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  // Where the tool presses: the surface point nearest (80, 30, 0) mm (the cylinder's side, radius 30 mm),
  // 5 mm in along its inward normal.
  const CommandRun probe = run_organsim("poke " + model + " --tool 80,30,0/0,0,0 --json", dir_);
  ASSERT_EQ(probe.exit_code, 0) << probe.err;
  const nlohmann::json at = nlohmann::json::parse(probe.out)["tools"][0];
  const auto a = at["action_point_mm"].get<std::vector<double>>(), n = at["normal"].get<std::vector<double>>();
  const Eigen::Vector3d action(a[0], a[1], a[2]), normal(n[0], n[1], n[2]);
  const CommandRun poke =
      run_organsim(fmt::format("poke {} --tool {:.9f},{:.9f},{:.9f}/{:.9f},{:.9f},{:.9f} --json --friction 1e6", model,
                               action[0], action[1], action[2], -5 * normal[0], -5 * normal[1], -5 * normal[2]),
                   dir_);
  ASSERT_EQ(poke.exit_code, 0) << poke.err;
  const auto f = nlohmann::json::parse(poke.out)["tools"][0]["force_n"].get<std::vector<double>>();
  const Eigen::Vector3d expected(f[0], f[1], f[2]);
  ASSERT_GT(expected.norm(), 1e-2);

  // With a friction no press overcomes the organ never slips: the force does
  // not depend on the way the press went (docs/realtime.md#contact-rule).
  const fs::path report = dir_ / "report";
  ServeProcess serve(
      model + " --igtl-port 0 --tools 2 --max-force 100 --max-stiffness 1e6 --json --friction 1e6 --report " +
          report.string(),
      dir_);
  const int port = serve.port();
  ASSERT_GT(port, 0);
  IgtlClient client(port);
  ASSERT_TRUE(client.connected());
  Received r;
  // 10 mm outside, then in along the normal over 0.3 s (the shaft points out), then held.
  client.send_tip(action + 10 * normal, normal);
  client.receive_for(0.2, r);
  ASSERT_GE(r.surfaces, 1) << "a client gets the organ when it connects";
  const std::vector<Eigen::Vector3d> rest = r.surface;
  for (int step = 1; step <= 30; ++step) {
    client.send_tip(action + (10.0 - 15.0 * step / 30.0) * normal, normal);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  client.receive_for(1.0, r);
  ASSERT_EQ(r.forces.count("tool1_force"), 1u);
  ASSERT_EQ(r.forces.count("tool2_force"), 1u);
  const Eigen::Vector3d force = r.forces["tool1_force"];
  EXPECT_LT((force - expected).norm(), 1e-4 * expected.norm() + 1e-6)
      << "serve " << force.transpose() << " N, poke " << expected.transpose() << " N";
  EXPECT_EQ(r.forces["tool2_force"].norm(), 0.0);
  ASSERT_EQ(r.surface.size(), rest.size());
  double moved = 0.0;
  for (std::size_t v = 0; v < rest.size(); ++v) moved = std::max(moved, (r.surface[v] - rest[v]).norm());
  EXPECT_GT(moved, 4.0) << "mm: the pressed surface follows the tool";
  EXPECT_GT(r.force_messages, 60) << "forces come at 60 Hz";

  const CommandRun done = serve.stop();
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const nlohmann::json summary = nlohmann::json::parse(done.out);
  EXPECT_EQ(summary["tools"][0]["contacts"], 1);
  EXPECT_EQ(summary["clients_accepted"], 1);
  EXPECT_EQ(summary["poses"], 31);
  // The training report of the served session: the press's depth and force.
  EXPECT_EQ(summary["report"], (report / "index.html").string());
  std::ifstream in(report / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(in);
  ASSERT_EQ(metrics["tools"].size(), 2u);
  EXPECT_NEAR(metrics["tools"][0]["peak_depth_mm"].get<double>(), 5.0, 0.05);
  EXPECT_NEAR(metrics["tools"][0]["peak_force_n"].get<double>(), expected.norm(), 1e-3 * expected.norm());
  EXPECT_EQ(metrics["tools"][1]["peak_force_n"].get<double>(), 0.0);
}

// A client closes tool 1's jaws with a STRING message once the tool is 3 mm
// in, then lifts it 5 mm above the rest surface: the organ follows and pulls
// the tool back (the force points into the organ); the jaws counted once.
TEST_F(Cli, ServeGraspsWhenAClientClosesAToolsJaws) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const Eigen::Vector3d action(80.0, 30.0, 0.0), normal(0.0, 1.0, 0.0);  // the cylinder's side, mm
  ServeProcess serve(model + " --igtl-port 0 --tools 1 --json", dir_);
  const int port = serve.port();
  ASSERT_GT(port, 0);
  IgtlClient client(port);
  ASSERT_TRUE(client.connected());
  Received r;
  client.send_tip(action + 10 * normal, normal);
  client.receive_for(0.2, r);
  ASSERT_GE(r.surfaces, 1);
  const std::vector<Eigen::Vector3d> rest = r.surface;
  for (int step = 1; step <= 26; ++step) {  // 10 mm out to 3 mm in
    client.send_tip(action + (10.0 - 0.5 * step) * normal, normal);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  client.receive_for(0.2, r);
  client.send(testing::string_message("tool1", "closed"));
  client.receive_for(0.2, r);
  for (int step = 1; step <= 16; ++step) {  // 3 mm in to 5 mm out
    client.send_tip(action + (-3.0 + 0.5 * step) * normal, normal);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  client.receive_for(0.5, r);
  ASSERT_EQ(r.forces.count("tool1_force"), 1u);
  EXPECT_LT(r.forces["tool1_force"].dot(normal), -1e-4) << "N: the lifted side pulls the tool back";
  double lifted = 0.0;
  for (std::size_t v = 0; v < rest.size(); ++v)
    lifted = std::max(lifted, r.surface[v].dot(normal) - rest[v].dot(normal));
  EXPECT_GT(lifted, 3.0) << "mm: the side follows the jaws up";
  const CommandRun done = serve.stop();
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const nlohmann::json summary = nlohmann::json::parse(done.out);
  EXPECT_EQ(summary["jaw_changes"], 1);
  EXPECT_EQ(summary["tools"][0]["grasps"], 1);
  EXPECT_EQ(summary["tools"][0]["contacts"], 1);
  EXPECT_GT(summary["tools"][0]["peak_pull_n"].get<double>(), 1e-4);
}

// --force-rate 1000: each tool's force reaches the client at the haptic rate,
// between the 60 Hz frames.
TEST_F(Cli, ServeSendsForcesAtTheForceRate) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  ServeProcess serve(model + " --igtl-port 0 --tools 1 --force-rate 1000 --json", dir_);
  const int port = serve.port();
  ASSERT_GT(port, 0);
  IgtlClient client(port);
  ASSERT_TRUE(client.connected());
  // The count starts once the server serves: on a loaded CI machine its
  // set-up (locking its memory) outlasted the test's second once, and the
  // client got nothing at all.
  Received first;
  for (int tries = 0; tries < 100 && first.surfaces == 0; ++tries) client.receive_for(0.1, first);
  ASSERT_GE(first.surfaces, 1) << "the organ within 10 s of connecting";
  Received r;
  client.send_tip({80, 50, 0}, {0, 1, 0});
  client.receive_for(1.0, r);
  // 1,000 a second. A loaded 2-core CI machine sleeps longer than asked (491
  // were measured there), so the test asks for what no 60 Hz server sends:
  // more than four times the frame rate.
  EXPECT_GT(r.force_messages, 4 * 60) << "forces in 1 s at --force-rate 1000";
  const CommandRun done = serve.stop();
  ASSERT_EQ(done.exit_code, 0) << done.err;
  EXPECT_GT(nlohmann::json::parse(done.out)["force_updates"].get<int>(), 4 * 60);
  const CommandRun slow = run_organsim("serve " + model + " --igtl-port 0 --force-rate 30 --seconds 0.1", dir_);
  EXPECT_EQ(slow.exit_code, 2);  // below the frame rate: a usage error
}

// A client beyond the eighth gets a STATUS message saying why, then the
// connection closes; once one of the eight leaves, a newcomer is served.
TEST_F(Cli, ServeRefusesAClientBeyondTheMaximumWithAStatusMessage) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  ServeProcess serve(model + " --igtl-port 0 --tools 1 --json", dir_);
  const int port = serve.port();
  ASSERT_GT(port, 0);
  // Whether a client gets the organ (sent once when it connects) within 10 s.
  const auto served = [](IgtlClient& client) {
    Received r;
    for (int tries = 0; tries < 100 && r.surfaces == 0; ++tries) client.receive_for(0.1, r);
    return r.surfaces == 1;
  };
  std::vector<std::unique_ptr<IgtlClient>> eight;
  for (int k = 0; k < 8; ++k) {
    eight.push_back(std::make_unique<IgtlClient>(port));
    ASSERT_TRUE(eight.back()->connected());
    ASSERT_TRUE(served(*eight.back())) << "client " << k + 1;
  }
  igtl::ClientSocket::Pointer ninth = igtl::ClientSocket::New();
  ASSERT_EQ(ninth->ConnectToServer("127.0.0.1", port), 0);
  ninth->SetReceiveTimeout(5000);
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  ASSERT_EQ(ninth->Receive(header->GetPackPointer(), header->GetPackSize()), header->GetPackSize());
  header->Unpack();
  ASSERT_STREQ(header->GetDeviceType(), "STATUS");
  igtl::StatusMessage::Pointer status = igtl::StatusMessage::New();
  status->SetMessageHeader(header);
  status->AllocatePack();
  ASSERT_EQ(ninth->Receive(status->GetPackBodyPointer(), status->GetPackBodySize()), status->GetPackBodySize());
  ASSERT_TRUE(status->Unpack(1) & igtl::MessageHeader::UNPACK_BODY);
  EXPECT_EQ(status->GetCode(), igtl::StatusMessage::STATUS_BUSY);
  EXPECT_NE(std::string(status->GetStatusString()).find("at most 8 clients"), std::string::npos)
      << status->GetStatusString();
  char byte = 0;
  EXPECT_EQ(ninth->Receive(&byte, 1), 0) << "the refused connection is closed";

  // Once the server has seen one of the eight leave (on a loaded machine the
  // kernel may hand it the newcomer before the leaver's close), a newcomer is served.
  eight.front()->close();
  eight.erase(eight.begin());
  for (auto until = Clock::now() + std::chrono::seconds(10);
       Clock::now() < until && serve.err().find(" disconnected (") == std::string::npos;)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  IgtlClient newcomer(port);
  ASSERT_TRUE(newcomer.connected());
  EXPECT_TRUE(served(newcomer)) << "a place freed is a place taken";
  const CommandRun done = serve.stop();
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const nlohmann::json summary = nlohmann::json::parse(done.out);
  EXPECT_EQ(summary["clients_refused"], 1);
  EXPECT_EQ(summary["clients_accepted"], 9);
  EXPECT_NE(done.err.find("refused: 8 clients are connected already"), std::string::npos) << done.err;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST_F(Cli, ServeLogsBadMessagesOnceDropsThemAndServesAClientThatComesBack) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  ServeProcess serve(model + " --igtl-port 0 --tools 2 --json", dir_);
  const int port = serve.port();
  ASSERT_GT(port, 0);
  const std::array<float, 12> nan_pose = {1, 0, 0, 0, 1, 0, 0, 0, 1, std::nanf(""), 0, 0};
  const std::array<float, 12> far_pose = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1e9f, 0, 0};
  {
    IgtlClient client(port);
    ASSERT_TRUE(client.connected());
    for (int twice = 0; twice < 2; ++twice) {
      client.send(testing::raw_message("TRANSFORM", "tool1", testing::transform_body(nan_pose)));
      client.send(testing::raw_message("TRANSFORM", "tool1", testing::transform_body(far_pose)));
      client.send(testing::raw_message("TRANSFORM", "tool1", testing::transform_body(nan_pose), 1, true));
      client.send(testing::raw_message("TRANSFORM", "tool1", testing::Bytes(40, 0)));
      client.send(testing::raw_message("STATUS", "tracker", testing::Bytes(30, 0)));
      client.send(testing::transform_message("tool7", {1, 2, 3}));
    }
    client.send(testing::transform_message("tool2", {80, 60, 0}));  // a good pose among them
    Received r;
    client.receive_for(0.3, r);
    EXPECT_GE(r.surfaces, 1) << "the connection stays up after bad messages";
    client.send(testing::Bytes(64, 0xee));  // garbage: the stream is out of step and the server closes it
    client.receive_for(0.3, r);
    client.close();
  }
  // The same client connects again and is served.
  IgtlClient again(port);
  ASSERT_TRUE(again.connected());
  Received r;
  again.receive_for(0.3, r);
  EXPECT_GE(r.surfaces, 1);
  EXPECT_GE(r.force_messages, 2);

  const CommandRun done = serve.stop();
  ASSERT_EQ(done.exit_code, 0) << done.err;
  for (const char* logged : {"holds NaN or infinite values", "more than 10 m from the organ", "failed its CRC check",
                             "wrong size for a TRANSFORM", "of a type serve does not read",
                             "not named after a tool served", "cannot start a message"})
    EXPECT_EQ(count(done.err, logged), 1) << logged << " in:\n" << done.err;
  EXPECT_EQ(count(done.err, " connected\n"), 2) << done.err;
  EXPECT_EQ(count(done.err, "disconnected (the stream was out of step)"), 1) << done.err;
  const nlohmann::json summary = nlohmann::json::parse(done.out);
  const nlohmann::json& dropped = summary["dropped"];
  EXPECT_EQ(dropped["non_finite"], 2);
  EXPECT_EQ(dropped["too_far"], 2);
  EXPECT_EQ(dropped["bad_crc"], 2);
  EXPECT_EQ(dropped["wrong_size"], 2);
  EXPECT_EQ(dropped["unknown_type"], 2);
  EXPECT_EQ(dropped["unknown_device"], 2);
  EXPECT_EQ(dropped["out_of_step"], 1);
  EXPECT_EQ(summary["poses"], 1);
  EXPECT_EQ(summary["clients_accepted"], 2);
}

TEST_F(Cli, ServeRefusesAPortInUseInOneLine) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  fs::create_directories(dir_ / "first");
  ServeProcess first(model + " --igtl-port 0", dir_ / "first");
  const int port = first.port();
  ASSERT_GT(port, 0);
  const CommandRun second = run_organsim(fmt::format("serve {} --igtl-port {} --seconds 1", model, port), dir_);
  EXPECT_EQ(second.exit_code, 1);
  EXPECT_NE(second.err.find(fmt::format("cannot listen on 127.0.0.1:{}: Address already in use", port)),
            std::string::npos)
      << second.err;
  const CommandRun bad_bind = run_organsim("serve " + model + " --bind 300.1.2.3 --seconds 1", dir_);
  EXPECT_EQ(bad_bind.exit_code, 2) << bad_bind.err;
}

}  // namespace
}  // namespace organsim
