// The server's life around broken calls: cancelled streams, passed deadlines, clients that vanish
// mid-upload, and SIGTERM while a stream runs.
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

v1::Stats get_stats(v1::RenderService::Stub& stub) {
  grpc::ClientContext context;
  v1::Stats stats;
  EXPECT_TRUE(stub.GetStats(&context, {}, &stats).ok());
  return stats;
}

// Calls of `method` ("rpc/UploadScene") that finished, as GetStats counts them.
uint64_t finished_calls(v1::RenderService::Stub& stub, const std::string& method) {
  const v1::Stats stats = get_stats(stub);
  for (const v1::LatencySummary& s : stats.latencies()) {
    if (s.stage() == method) return s.count();
  }
  return 0;
}

void wait_for_finished_calls(v1::RenderService::Stub& stub, const std::string& method,
                             uint64_t count) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (finished_calls(stub, method) < count && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(finished_calls(stub, method), count) << method;
}

// Polls until the server has no stream running (a cancelled stream ends at its next pass).
void wait_for_streams_to_end(v1::RenderService::Stub& stub) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (get_stats(stub).active_streams() > 0 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(get_stats(stub).active_streams(), 0u);
}

// Starts a stream that would run for 100000 passes and reads its first frame into `first`.
std::unique_ptr<grpc::ClientReader<v1::Frame>> start_endless_stream(v1::RenderService::Stub& stub,
                                                                    grpc::ClientContext& context,
                                                                    const std::string& scene_id,
                                                                    v1::Frame* first) {
  v1::StreamFramesRequest request;
  request.set_scene_id(scene_id);
  request.set_target_passes(100000);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  set_deadline(context);
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader = stub.StreamFrames(&context, request);
  EXPECT_TRUE(reader->Read(first));
  return reader;
}

// Server reflection answers a service listing the way grpcurl asks for one. Debian ships the
// reflection service without its client headers, so the request is encoded by hand:
// ServerReflectionRequest{list_services: ""} is field 7, an empty string.
TEST_F(ServerTest, ReflectionListsTheRenderService) {
  grpc::GenericStub stub(server_->channel());
  grpc::CompletionQueue queue;
  grpc::ClientContext context;
  auto call = stub.PrepareCall(
      &context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &queue);
  auto step = [&](int tag) {
    void* got = nullptr;
    bool ok = false;
    EXPECT_TRUE(queue.Next(&got, &ok));
    EXPECT_EQ(got, reinterpret_cast<void*>(intptr_t{tag}));
    return ok;
  };
  call->StartCall(reinterpret_cast<void*>(intptr_t{1}));
  ASSERT_TRUE(step(1));
  const std::string request("\x3a\x00", 2);
  grpc::Slice slice(request);
  grpc::ByteBuffer out(&slice, 1);
  call->Write(out, reinterpret_cast<void*>(intptr_t{2}));
  ASSERT_TRUE(step(2));
  grpc::ByteBuffer in;
  call->Read(&in, reinterpret_cast<void*>(intptr_t{3}));
  ASSERT_TRUE(step(3));
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(in.Dump(&slices).ok());
  std::string response;
  for (const grpc::Slice& s : slices)
    response.append(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_NE(response.find("caustica.v1.RenderService"), std::string::npos);
  EXPECT_NE(response.find("grpc.health.v1.Health"), std::string::npos);
  call->WritesDone(reinterpret_cast<void*>(intptr_t{4}));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(intptr_t{5}));
  step(5);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

TEST_F(ServerTest, CancelledStreamLeavesTheServerHealthy) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 1));
  grpc::ClientContext context;
  v1::Frame frame;
  auto reader = start_endless_stream(*stub_, context, id, &frame);
  ASSERT_TRUE(reader->Read(&frame));
  EXPECT_EQ(frame.passes(), 2u);
  context.TryCancel();
  while (reader->Read(&frame)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  wait_for_streams_to_end(*stub_);
  expect_server_healthy(*server_);
  // The cancelled stream's scene still renders.
  v1::Frame more;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA8_SRGB), &more).ok());
  EXPECT_GE(more.passes(), 2u);
}

TEST_F(ServerTest, DeadlineIsHonouredBetweenPasses) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 1));
  grpc::ClientContext context;
  set_deadline(context, 0.5);
  v1::RenderFrameRequest request;
  request.set_scene_id(id);
  request.set_target_passes(100000);
  v1::Frame frame;
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status status = stub_->RenderFrame(&context, request, &frame);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  wait_for_finished_calls(*stub_, "rpc/RenderFrame", 1);
  // The handler stopped within a pass or so: the next call is not stuck behind 100000 passes.
  expect_server_healthy(*server_);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  v1::SceneInfo info = get_stats(*stub_).scene_stats(0);
  EXPECT_LT(info.passes(), 100000u);
}

TEST_F(ServerTest, ClientThatDisconnectsDuringUploadLeavesNoScene) {
  const uint64_t memory_before = get_stats(*stub_).memory_used_bytes();
  // Small chunks so the upload is many messages; stop after half of them.
  const std::vector<v1::SceneChunk> chunks =
      scene_chunks(cornell_box(16, 16, 2000, 16, 1), "half", 64);
  ASSERT_GT(chunks.size(), 4u);
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::SceneInfo info;
    auto writer = stub_->UploadScene(&context, &info);
    for (size_t i = 0; i < chunks.size() / 2; ++i) ASSERT_TRUE(writer->Write(chunks[i]));
    context.TryCancel();  // what the server sees when a client goes away (RST_STREAM)
    EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }
  // The upload handler ended without turning into a scene.
  wait_for_finished_calls(*stub_, "rpc/UploadScene", 1);
  grpc::ClientContext context;
  v1::ListScenesResponse list;
  ASSERT_TRUE(stub_->ListScenes(&context, {}, &list).ok());
  EXPECT_EQ(list.scenes_size(), 0);
  EXPECT_EQ(get_stats(*stub_).memory_used_bytes(), memory_before);
  expect_server_healthy(*server_);
}

TEST_F(ServerTest, SigtermDuringAStreamExitsCleanly) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 1));
  grpc::ClientContext context;
  v1::Frame frame;
  auto reader = start_endless_stream(*stub_, context, id, &frame);
  EXPECT_EQ(server_->terminate(), 0) << server_->log();
  while (reader->Read(&frame)) {
  }
  const grpc::Status status = reader->Finish();
  EXPECT_FALSE(status.ok());
  EXPECT_TRUE(status.error_code() == grpc::StatusCode::UNAVAILABLE ||
              status.error_code() == grpc::StatusCode::CANCELLED)
      << status.error_code() << ": " << status.error_message();
  const std::string log = server_->log();
  EXPECT_NE(log.find("shutting down"), std::string::npos) << log;
  EXPECT_NE(log.find("StreamFrames"), std::string::npos) << "the stream's request line";
}

}  // namespace
}  // namespace caustica::testing
