#include "sag_hand_tracker/ros/bag_input.h"

#include <bzlib.h>
#include <ros/exception.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/message_bounds.h"
#include "sag_hand_tracker/tracking/camera_set_synchronizer.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

const char* const kImageType = "sensor_msgs/Image";
const char* const kCameraInfoType = "sensor_msgs/CameraInfo";
const char* const kTfType = "tf2_msgs/TFMessage";
const char* const kTfStaticTopic = "/tf_static";
// An image that starts a set of its own while another camera's set without it lies within half
// its camera's frame period, and at least this (but beyond the stamp tolerance), is a stamp
// mismatch: the cameras are not stamped together. Half the frame period at 25 fps; at higher
// rates a camera that skips a frame can be counted too. Inclusive: a camera exactly half a period
// late is as far from both neighbouring sets and was missed (20 ms at 25 fps, 40 at 12.5).
constexpr std::int64_t kNearStampNs = 20000000;
// A camera's stamps that leap forward by more than this (a clock set forward, a paused recording)
// are reported: the tracker takes the frames as consecutive.
constexpr std::int64_t kStampJumpNs = static_cast<std::int64_t>(kStampJumpSeconds * 1e9);

std::string imageTopic(int id) { return "/cam" + std::to_string(id) + "/image_raw"; }
std::string cameraInfoTopic(int id) { return "/cam" + std::to_string(id) + "/camera_info"; }
std::string cameraName(int id) { return "cam" + std::to_string(id); }

std::string stripSlash(const std::string& frame) {
  return !frame.empty() && frame.front() == '/' ? frame.substr(1) : frame;
}

std::string formatStamp(std::int64_t stamp_ns) {
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.6f", static_cast<double>(stamp_ns) * 1e-9);
  return buffer;
}

std::string joinIds(const std::vector<int>& ids) {
  std::string text;
  for (int id : ids) text += (text.empty() ? "" : " ") + std::to_string(id);
  return text;
}

template <class M>
bool bytesAre(const std::vector<std::uint8_t>& bytes) {
  return checkSerializedMessage(ros::message_traits::datatype<M>(),
                                ros::message_traits::definition<M>(), bytes.data(), bytes.size())
      .empty();
}

// The type, among those a camera bag holds, whose layout the bytes of `message` fit exactly; ""
// when none does. For the error about a message that is not its connection's type: rosbag (C++
// and Python) keeps a topic's first connection, so a std_msgs/String written on an image topic is
// stored as a sensor_msgs/Image, and "malformed sensor_msgs/Image" did not say what it was.
std::string typeOfBytes(const rosbag::MessageInstance& message) {
  std::vector<std::uint8_t> bytes(message.size());
  ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  message.write(out);
  if (bytesAre<std_msgs::String>(bytes)) return "std_msgs/String";
  if (bytesAre<sensor_msgs::CompressedImage>(bytes)) return "sensor_msgs/CompressedImage";
  if (bytesAre<sensor_msgs::CameraInfo>(bytes)) return "sensor_msgs/CameraInfo";
  if (bytesAre<sensor_msgs::Image>(bytes)) return "sensor_msgs/Image";
  if (bytesAre<tf2_msgs::TFMessage>(bytes)) return "tf2_msgs/TFMessage";
  return "";
}

struct ParentLink {
  std::string parent;
  Eigen::Isometry3d parent_to_child;  // tf: the pose of the child frame in the parent frame
  int message = 0;                    // the /tf_static message (1, 2, ...) that gave it
  std::string conflict;  // a later message that gave this frame another pose (empty: none)
};

// Re-recorded static transforms (a latched publisher seen twice) repeat the same pose to within
// float rounding; a camera that moved differs by far more.
constexpr double kSamePoseMetres = 1e-6;
constexpr double kSamePoseRadians = 1e-6;

}  // namespace

struct BagReader::Impl {
  struct PendingSet {
    std::vector<CameraImage> images;  // sorted by camera index
    bool has(int camera) const {
      return std::any_of(images.begin(), images.end(),
                         [camera](const CameraImage& image) { return image.camera == camera; });
    }
  };

  Impl(const std::string& bag_path, const BagReaderOptions& bag_options, rosbag::Bag* reused_bag)
      : path(bag_path),
        options(bag_options),
        own_bag(reused_bag ? nullptr : std::make_unique<rosbag::Bag>()),
        bag(reused_bag ? *reused_bag : *own_bag) {
    options.max_pending_sets = std::max(1, options.max_pending_sets);
    stats.stamp_tolerance = options.stamp_tolerance;
    if (!(options.stamp_tolerance >= 0.0 && options.stamp_tolerance <= 1.0)) {
      throw InputError("stamp tolerance must be within [0, 1] s, got " +
                       std::to_string(options.stamp_tolerance));
    }
  }

  std::string path;
  BagReaderOptions options;
  std::unique_ptr<rosbag::Bag> own_bag;  // null when reading through a caller's bag
  rosbag::Bag& bag;
  // Closes the bag when the reader goes (after the views on it, declared below), so that a
  // caller's reused bag is closed for its next file whether this one was read or refused.
  struct CloseBag {
    rosbag::Bag& bag;
    ~CloseBag() { bag.close(); }
  } close_bag{bag};
  std::string root_frame;
  std::vector<Camera> cameras;
  std::vector<int> ids;
  std::vector<std::string> optical_frames;
  // Per camera, its first camera_info (the one that became the camera; later ones must match it).
  std::vector<sensor_msgs::CameraInfo::ConstPtr> first_infos;
  std::map<std::string, int> topic_to_camera;

  std::unique_ptr<rosbag::View> view;
  rosbag::View::iterator it;
  rosbag::View::iterator end;
  std::map<std::int64_t, PendingSet> pending;
  std::vector<std::int64_t> last_stamp;    // per camera, newest stamp seen
  std::vector<std::uint64_t> frames_read;  // per camera, its images read so far (frame numbers)
  std::vector<std::int64_t> frame_period;  // per camera, its shortest step between stamps so far
  bool yielded_any = false;
  std::int64_t last_yielded = 0;
  BagReaderStatistics stats;

  // Runs `action`; rosbag's and roscpp's exceptions become InputError naming the bag.
  template <typename Action>
  void translateErrors(Action action) const {
    try {
      action();
    } catch (const InputError&) {
      throw;
    } catch (const rosbag::BagException& exception) {
      fail(std::string("cannot read the bag: ") + exception.what());
    } catch (const ros::Exception& exception) {
      fail(std::string("cannot read the bag: ") + exception.what());
    }
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path + ": " + problem);
  }

  // The message as an M (null when its connection has another type), its length prefixes checked
  // against its bytes before roscpp allocates what they declare (ros/message_bounds.h).
  template <class M>
  boost::shared_ptr<M> read(const rosbag::MessageInstance& message) const {
    try {
      return instantiateChecked<M>(message);
    } catch (const std::runtime_error& error) {
      const std::string found = typeOfBytes(message);
      const std::string expected = ros::message_traits::datatype<M>();
      fail(message.getTopic() + " at " + formatStamp(message.getTime().toNSec()) + ": " +
           error.what() +
           (found.empty() || found == expected
                ? std::string()
                : "; its bytes are a " + found + ", not a " + expected +
                      " (another type written on the topic under its first connection)"));
    }
  }

  void open();
  std::vector<int> discoverCameras();
  void readCameraInfo();
  void readExtrinsics();
  void checkFirstImages();
  cv::Mat decode(const sensor_msgs::Image& image, int camera, const std::string& topic) const;
  bool frontIsFinal() const;
  std::map<std::int64_t, PendingSet>::iterator setFor(int camera, std::int64_t stamp);
  // `image` names the image (made only when its note is the first of its kind).
  void noteNearStamps(const std::function<std::string()>& image, int camera, std::int64_t stamp);
  void noteDuplicateStamp(const std::function<std::string()>& image, std::int64_t stamp);
  bool step(FrameSet* set);
};

// rosbag allocates whatever a record's length fields say before it checks them against the file
// (a flipped bit: gigabytes, or std::bad_alloc), and parses record headers where they lie, copying
// whatever length a field claims. So the record structure is walked first: every record
// <header_len><header><data_len><data> must fit in the file (a chunk's records in their chunk),
// header fields must fit in their header, a chunk's uncompressed size must be at most
// kMaxChunkBytes, index records and chunk infos must hold the number of entries their count
// says, and index entries and chunk infos must point at records. Compressed chunks (lz4,
// bz2) are decompressed here as rosbag will, and their records walked like an uncompressed
// chunk's (a fuzz find: an index entry into a record of an lz4 chunk made rosbag parse message
// bytes as a header and read past its buffer).
// Returns "" or what is wrong.
class BagRecordWalker {
 public:
  explicit BagRecordWalker(const std::string& path) : file_(path, std::ios::binary) {}

  // The records after the magic line "#ROSBAG V2.0\n" up to `size`; `index_pos` (from the bag
  // header) must be where one of them starts, or the end of the file when the bag has no index
  // records (rosbag reads a record header wherever it points: a header length from the middle of
  // a record made it allocate 2.3 GB).
  std::string walkFile(std::uint64_t size, std::uint64_t index_pos) {
    const std::string problem = walk(Source{}, 13, size, nullptr);
    if (!problem.empty()) return problem;
    if (index_pos != size && !file_record_starts_.count(index_pos)) {
      return "the bag is corrupt: its header's index position (byte " + std::to_string(index_pos) +
             ") is not where a record starts";
    }
    return "";
  }

 private:
  // rosbag's own limit is 4 GiB (a 32-bit size); a chunk is normally about 768 kB (rosbag's
  // chunk threshold) plus one message. Checked before the decompressed chunk is allocated.
  static constexpr std::uint32_t kMaxChunkBytes = 1u << 30;

  // Where records are read from: the file (positions in it), or a decompressed chunk in memory
  // (positions in its uncompressed data).
  struct Source {
    const char* memory = nullptr;  // null: the file
    std::uint64_t size = 0;
  };
  // The chunk whose records are being walked.
  struct Chunk {
    std::uint64_t record_at = 0;  // file position of the chunk record
    std::string compression;
  };

  std::string walk(const Source& source, std::uint64_t begin, std::uint64_t end,
                   const Chunk* chunk) {
    const std::string container = chunk ? "its chunk" : "the file";
    const auto corrupt = [&](std::uint64_t pos, const std::string& what) {
      return describe(chunk, pos, what);
    };
    std::uint64_t pos = begin;
    while (pos < end) {
      std::uint32_t header_len = 0, data_len = 0;
      if (end - pos < 4 || !readU32(source, pos, &header_len)) return corrupt(pos, "a cut record");
      if (header_len > end - pos - 4) {
        return corrupt(pos, "a record header longer than " + container);
      }
      std::string header(header_len, '\0');
      if (!read(source, pos + 4, &header[0], header_len)) {
        return corrupt(pos, "an unreadable header");
      }
      const std::uint64_t data_at = pos + 4 + header_len;
      if (end - data_at < 4 || !readU32(source, data_at, &data_len)) {
        return corrupt(pos, "a cut record");
      }
      if (data_len > end - data_at - 4) return corrupt(pos, "record data longer than " + container);
      std::map<std::string, std::string> fields;
      if (!parseFields(header, &fields)) return corrupt(pos, "a record header with a cut field");
      const std::string op = fields["op"];
      if (op.size() != 1) return corrupt(pos, "a record without its op field");
      if (op[0] == 0x03 && !chunk) {  // the bag header
        const std::string encryptor = fields["encryptor"];
        if (!encryptor.empty() && encryptor != "rosbag/NoEncryptor") {
          return "the bag is encrypted (" + encryptor + "): encrypted bags are not supported";
        }
      }
      if (op[0] == 0x07) {  // connection: its data is a header too (topic, type, definition)
        std::string data(data_len, '\0');
        std::map<std::string, std::string> connection;
        if (!read(source, data_at + 4, &data[0], data_len) || !parseFields(data, &connection)) {
          return corrupt(pos, "a connection record with a cut field");
        }
      }
      if (op[0] == 0x05) {
        if (chunk) return corrupt(pos, "a chunk inside a chunk");
        const std::string problem = walkChunk(pos, fields, data_at + 4, data_len);
        if (!problem.empty()) return problem;
        chunk_starts_.insert(pos);
      }
      if (chunk) {
        record_offsets_.insert(pos - begin);
      } else {
        file_record_starts_.insert(pos);
      }
      if ((op[0] == 0x04 || op[0] == 0x06) && !chunk) {
        // rosbag reads as many entries as the header's count says, not as the data holds: more
        // made it read on into the next records and take a header length from the middle of one
        // (a fuzz find: 2.3 GB allocated).
        const std::string record = op[0] == 0x04 ? "an index record" : "a chunk info";
        const std::uint64_t entry_bytes = op[0] == 0x04 ? 12 : 8;
        std::uint32_t count = 0;
        if (fields["count"].size() != 4) return corrupt(pos, record + " without its count");
        std::memcpy(&count, fields["count"].data(), 4);
        if (count * entry_bytes != data_len) {
          return corrupt(pos, record + " of " + std::to_string(count) + " entries (" +
                                  std::to_string(count * entry_bytes) + " bytes) in " +
                                  std::to_string(data_len) + " bytes of data");
        }
      }
      if (op[0] == 0x04 && !chunk) {  // index of the chunk before: (time, offset) entries
        const std::string problem = checkIndexOffsets(pos, data_at + 4, data_len);
        if (!problem.empty()) return problem;
      }
      if (op[0] == 0x06 && !chunk) {  // chunk info: where its chunk record starts
        std::uint64_t chunk_pos = 0;
        if (fields["chunk_pos"].size() != 8) return corrupt(pos, "a chunk info without chunk_pos");
        std::memcpy(&chunk_pos, fields["chunk_pos"].data(), 8);
        if (!chunk_starts_.count(chunk_pos)) {
          return corrupt(pos, "a chunk info pointing where no chunk starts");
        }
      }
      pos = data_at + 4 + data_len;
    }
    return "";
  }

  // The records of the chunk record at `record_at`, whose data (as stored) is `data_len` bytes at
  // file position `data_at`; its header's `size` is the uncompressed size rosbag will allocate.
  std::string walkChunk(std::uint64_t record_at, std::map<std::string, std::string>& fields,
                        std::uint64_t data_at, std::uint32_t data_len) {
    const auto corrupt = [&](const std::string& what) {
      return describe(nullptr, record_at, what);
    };
    const std::string compression = fields["compression"];
    if (fields["size"].size() != 4) return corrupt("a chunk without its size");
    std::uint32_t size = 0;
    std::memcpy(&size, fields["size"].data(), 4);
    record_offsets_.clear();
    const Chunk chunk{record_at, compression};
    latest_chunk_ = chunk;
    if (compression == "none") {
      if (size != data_len) return corrupt("a chunk whose size disagrees");
      return walk(Source{}, data_at, data_at + data_len, &chunk);
    }
    if (compression != "lz4" && compression != "bz2") {
      return corrupt("a chunk of unknown compression '" + compression + "'");
    }
    const auto bad_chunk = [&](const std::string& problem) {
      return "the bag is corrupt: the " + compression + " chunk at byte " +
             std::to_string(record_at) + " " + problem;
    };
    if (size > kMaxChunkBytes) {
      return bad_chunk("declares " + std::to_string(size) +
                       " uncompressed bytes (the limit is 1 GiB)");
    }
    // Not zero-filled: a chunk that declares much more than it holds costs no page.
    const std::unique_ptr<char[]> stored(new char[data_len]);
    if (!read(Source{}, data_at, stored.get(), data_len)) return bad_chunk("is unreadable");
    const std::unique_ptr<char[]> plain(new char[size]);
    unsigned int produced = size;
    const std::string too_much =
        "decompresses to more than the " + std::to_string(size) + " bytes it declares";
    if (compression == "lz4") {
      const int result =
          roslz4_buffToBuffDecompress(stored.get(), data_len, plain.get(), &produced);
      if (result == ROSLZ4_OUTPUT_SMALL) return bad_chunk(too_much);
      if (result != ROSLZ4_OK) {
        return bad_chunk("is not valid lz4 data (roslz4 error " + std::to_string(result) + ")");
      }
    } else {
      const int result = BZ2_bzBuffToBuffDecompress(plain.get(), &produced, stored.get(), data_len,
                                                    /*small=*/0, /*verbosity=*/0);
      if (result == BZ_OUTBUFF_FULL) return bad_chunk(too_much);
      if (result != BZ_OK) {
        return bad_chunk("is not valid bzip2 data (bzip2 error " + std::to_string(result) + ")");
      }
    }
    if (produced != size) {
      return bad_chunk("decompresses to " + std::to_string(produced) + " bytes, not the " +
                       std::to_string(size) + " it declares");
    }
    return walk(Source{plain.get(), size}, 0, size, &chunk);
  }

  // rosbag parses a message's record header wherever an index entry's offset points (a fuzz find:
  // an offset into the middle of a record read past a buffer): it must be the start of one of the
  // records of its chunk (the chunk record just before the index record).
  std::string checkIndexOffsets(std::uint64_t record_at, std::uint64_t data_at,
                                std::uint32_t data_len) {
    if (data_len % 12 != 0) return describe(nullptr, record_at, "an index record of cut entries");
    std::string data(data_len, '\0');
    if (!read(Source{}, data_at, &data[0], data_len)) {
      return describe(nullptr, record_at, "an unreadable index record");
    }
    for (std::size_t at = 0; at < data.size(); at += 12) {
      if (chunk_starts_.empty()) {
        return describe(nullptr, record_at, "an index record before any chunk");
      }
      // rosbag makes a ros::Time of each entry's (sec, nsec), which throws std::runtime_error when
      // nsec carries the seconds past 32 bits (a fuzz find: an exception other than InputError).
      std::uint32_t sec = 0, nsec = 0, offset = 0;
      std::memcpy(&sec, &data[at], 4);
      std::memcpy(&nsec, &data[at + 4], 4);
      std::memcpy(&offset, &data[at + 8], 4);
      if (sec + std::uint64_t{nsec / 1000000000u} > std::numeric_limits<std::uint32_t>::max()) {
        return "the bag is corrupt: the index record at byte " + std::to_string(record_at) +
               " has a time out of range (" + std::to_string(sec) + " s " + std::to_string(nsec) +
               " ns)";
      }
      if (!record_offsets_.count(offset)) {
        return "the bag is corrupt: the index record at byte " + std::to_string(record_at) +
               " points at byte " + std::to_string(offset) + " of the " +
               latest_chunk_.compression + " chunk at byte " +
               std::to_string(latest_chunk_.record_at) + ", where none of its records starts";
      }
    }
    return "";
  }

  // Records of the file are named by their byte in it, records of an uncompressed chunk too;
  // records of a compressed chunk by their chunk and their byte in its uncompressed data.
  static std::string describe(const Chunk* chunk, std::uint64_t pos, const std::string& what) {
    if (!chunk || chunk->compression == "none") {
      return "the bag is corrupt: " + what + " at byte " + std::to_string(pos);
    }
    return "the bag is corrupt: in the " + chunk->compression + " chunk at byte " +
           std::to_string(chunk->record_at) + ": " + what + " at byte " + std::to_string(pos) +
           " of its uncompressed data";
  }

  std::set<std::uint64_t> file_record_starts_;  // file positions of the records outside chunks
  std::set<std::uint64_t> chunk_starts_;        // ... of the chunk records among them
  Chunk latest_chunk_;                          // the index records after a chunk are about it
  std::set<std::uint64_t> record_offsets_;      // its records: offsets in its (uncompressed) data

  // A header: fields <len><name>=<value>, each within the header (rosbag copies whatever length
  // a field claims: a fuzz find). False when one is cut or has no '='.
  static bool parseFields(const std::string& header, std::map<std::string, std::string>* fields) {
    for (std::size_t at = 0; at < header.size();) {
      if (header.size() - at < 4) return false;
      std::uint32_t field_len = 0;
      std::memcpy(&field_len, &header[at], 4);
      at += 4;
      if (field_len > header.size() - at) return false;
      const std::string field = header.substr(at, field_len);
      at += field_len;
      const std::size_t equals = field.find('=');
      if (equals == std::string::npos) return false;
      (*fields)[field.substr(0, equals)] = field.substr(equals + 1);
    }
    return true;
  }

  bool read(const Source& source, std::uint64_t pos, char* out, std::size_t n) {
    if (source.memory) {
      if (pos > source.size || n > source.size - pos) return false;
      std::memcpy(out, source.memory + pos, n);
      return true;
    }
    file_.clear();
    file_.seekg(static_cast<std::streamoff>(pos));
    file_.read(out, static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(file_.gcount()) == n;
  }
  bool readU32(const Source& source, std::uint64_t pos, std::uint32_t* value) {
    char bytes[4];
    if (!read(source, pos, bytes, 4)) return false;
    std::memcpy(value, bytes, 4);  // little-endian, as the format and this machine
    return true;
  }

  std::ifstream file_;
};

std::string describeCorruptRecords(const std::string& path, std::uint64_t size,
                                   std::uint64_t index_pos) {
  return BagRecordWalker(path).walkFile(size, index_pos);
}

// A bag (format 2.0) starts with "#ROSBAG V2.0\n" and a header record whose field index_pos is
// where the index (written last, on close) begins. Returns "" for a bag that looks complete, else
// why it is not: not a bag of format 2.0, truncated (the index lies beyond the end of the file) or
// never closed.
std::string describeIncompleteBag(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::string head(4096, '\0');
  file.read(&head[0], static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(file.gcount()));
  // rosbag itself takes any "#ROS<word> V<major>.<minor>" line and then reads the records without
  // checking their lengths (a fuzz find: "#ROSBA+ V2.0" read past a buffer), so only files with
  // the exact first line are given to it, after the record walk below.
  if (head.rfind("#ROSBAG V2.0\n", 0) != 0) {
    return "cannot read the bag: it is not a ROS bag of format 2.0 (the file must begin with "
           "'#ROSBAG V2.0')";
  }
  const std::string field = "index_pos=";
  const std::size_t at = head.find(field);
  if (at == std::string::npos || at + field.size() + 8 > head.size()) {
    return "the bag is truncated (its header is incomplete)";
  }
  std::uint64_t index_pos = 0;
  for (int byte = 7; byte >= 0; --byte) {
    index_pos = (index_pos << 8) | static_cast<unsigned char>(head[at + field.size() + byte]);
  }
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) return "";
  if (index_pos == 0) {
    return "the bag was not closed (no index): was the recording interrupted? 'rosbag reindex' "
           "may repair it";
  }
  if (index_pos > size) {
    return "the bag is truncated: it has " + std::to_string(size) +
           " bytes, its index starts at byte " + std::to_string(index_pos);
  }
  return describeCorruptRecords(path, size, index_pos);
}

void BagReader::Impl::open() {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) fail("bag file does not exist");
  if (std::filesystem::is_directory(path, error)) fail("is a directory, not a bag file");
  // Opening a FIFO blocks until a writer comes (and ignores SIGTERM meanwhile); a device or
  // socket is no bag either.
  if (!std::filesystem::is_regular_file(path, error)) {
    fail("is not a regular file (a FIFO, device or socket?), not a bag file");
  }
  const std::string incomplete = describeIncompleteBag(path);
  if (!incomplete.empty()) fail(incomplete);
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& exception) {
    fail(std::string("cannot read the bag: ") + exception.what());
  }
  rosbag::View all(bag);
  if (all.size() == 0) fail("the bag is empty: no frames");

  const std::vector<int> found = discoverCameras();
  if (options.cameras.empty()) {
    ids = found;
  } else {
    std::set<int> wanted(options.cameras.begin(), options.cameras.end());
    for (int id : wanted) {
      if (!std::binary_search(found.begin(), found.end(), id)) {
        fail("camera " + std::to_string(id) + " (" + imageTopic(id) +
             ") is not in the bag (cameras: " + joinIds(found) + ")");
      }
    }
    ids.assign(wanted.begin(), wanted.end());
  }
  cameras.resize(ids.size());
  optical_frames.resize(ids.size());
  first_infos.resize(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    topic_to_camera[imageTopic(ids[i])] = static_cast<int>(i);
  }
  readCameraInfo();
  readExtrinsics();

  std::vector<std::string> topics;
  for (int id : ids) topics.push_back(imageTopic(id));
  view = std::make_unique<rosbag::View>(bag, rosbag::TopicQuery(topics));
  stats.image_messages = view->size();
  if (stats.image_messages == 0) fail("no frames: the image topics hold no messages");
  for (const std::string& topic : topics) {
    stats.most_camera_images = std::max<std::uint64_t>(
        stats.most_camera_images, rosbag::View(bag, rosbag::TopicQuery(topic)).size());
  }
  checkFirstImages();
  it = view->begin();
  end = view->end();
  last_stamp.assign(ids.size(), std::numeric_limits<std::int64_t>::min());
  frames_read.assign(ids.size(), 0);
  frame_period.assign(ids.size(), std::numeric_limits<std::int64_t>::max());
}

std::vector<int> BagReader::Impl::discoverCameras() {
  static const std::regex image_topic("^/?cam([0-9]+)/image_raw$");
  static const std::regex compressed_topic("^/cam([0-9]{1,9})/image_raw/compressed$");
  rosbag::View all(bag);
  std::map<std::string, std::string> numbers;  // image topic -> its camera number as written
  std::set<std::string> other_topics;
  std::map<std::string, int> compressed;  // compressed image topic -> its camera number
  for (const rosbag::ConnectionInfo* connection : all.getConnections()) {
    std::smatch match;
    if (std::regex_match(connection->topic, match, compressed_topic)) {
      compressed[connection->topic] = std::stoi(match[1].str());
    }
    if (std::regex_match(connection->topic, match, image_topic)) {
      if (connection->datatype != kImageType) {
        fail(connection->topic + " has type " + connection->datatype + ", expected " + kImageType);
      }
      numbers[connection->topic] = match[1].str();
    } else {
      other_topics.insert(connection->topic);
    }
  }
  if (numbers.empty()) {
    std::string topics;
    for (const std::string& topic : other_topics) topics += (topics.empty() ? "" : ", ") + topic;
    fail("no image topics (/cam<i>/image_raw) in the bag; it has: " + topics);
  }
  if (numbers.size() > static_cast<std::size_t>(kMaxCameras)) {
    fail("the bag has " + std::to_string(numbers.size()) +
         " camera image topics, more than the limit of " + std::to_string(kMaxCameras) +
         " cameras");
  }
  std::set<int> found;
  for (const auto& [topic, digits] : numbers) {
    // Camera numbers name topics and frames: at most kMaxCameras - 1 (std::stoi threw on
    // /cam99999999999/). The topic must be the one its number names: /cam01/... or cam0/...
    // would be looked up as /cam1/..., /cam0/..., which the bag does not have.
    if (digits.size() > 9 || std::stoi(digits) >= kMaxCameras) {
      fail(topic + ": camera number " + digits + " is out of range (at most " +
           std::to_string(kMaxCameras - 1) + ")");
    }
    const int id = std::stoi(digits);
    if (topic != imageTopic(id)) {
      fail(topic + " is not a supported camera image topic: expected " + imageTopic(id) +
           " (with a leading slash and no leading zeros)");
    }
    found.insert(id);
  }
  // A camera recorded through image_transport's compressed plugin only would be left out
  // silently (its camera_info read, its images never): named, unless --cameras leaves it out.
  for (const auto& [topic, id] : compressed) {
    const bool wanted =
        options.cameras.empty() ||
        std::find(options.cameras.begin(), options.cameras.end(), id) != options.cameras.end();
    if (wanted && found.count(id) == 0) {
      fail(topic + ": camera " + cameraName(id) + " has compressed images only; the tracker " +
           "reads sensor_msgs/Image on " + imageTopic(id) +
           " (decompress them first, e.g. with image_transport's republish; track_bag --cameras "
           "can leave the camera out)");
    }
  }
  return std::vector<int>(found.begin(), found.end());
}

void BagReader::Impl::readCameraInfo() {
  std::vector<std::string> topics;
  std::map<std::string, int> info_to_camera;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    topics.push_back(cameraInfoTopic(ids[i]));
    info_to_camera[topics.back()] = static_cast<int>(i);
  }
  rosbag::View infos(bag, rosbag::TopicQuery(topics));
  for (const rosbag::ConnectionInfo* connection : infos.getConnections()) {
    if (connection->datatype != kCameraInfoType) {
      fail(connection->topic + " has type " + connection->datatype + ", expected " +
           kCameraInfoType);
    }
  }
  std::vector<bool> have(ids.size(), false);
  [[maybe_unused]] std::size_t missing = ids.size();
  for (const rosbag::MessageInstance& message : infos) {
    const int camera = info_to_camera.at(message.getTopic());
    const sensor_msgs::CameraInfo::ConstPtr info = read<sensor_msgs::CameraInfo>(message);
    if (!info) fail(message.getTopic() + " does not hold sensor_msgs/CameraInfo");
    if (have[camera]) {
      // One calibration per camera: a driver that changes resolution mid-bag is refused.
      const Camera& first = cameras[camera];
      if (static_cast<int>(info->width) != first.width ||
          static_cast<int>(info->height) != first.height) {
        fail(message.getTopic() + " at " + formatStamp(info->header.stamp.toNSec()) +
             ": the image size changes mid-bag from " + std::to_string(first.width) + "x" +
             std::to_string(first.height) + " to " + std::to_string(info->width) + "x" +
             std::to_string(info->height) + " (one calibration per camera is supported)");
      }
      // Only the first camera_info becomes the camera: a later one with another (or a
      // non-finite) K, D, distortion model, R or P would otherwise be ignored silently.
      const sensor_msgs::CameraInfo& was = *first_infos[camera];
      const bool finite =
          std::all_of(info->K.begin(), info->K.end(), [](double v) { return std::isfinite(v); }) &&
          std::all_of(info->D.begin(), info->D.end(), [](double v) { return std::isfinite(v); });
      const bool finite_rectification =
          std::all_of(info->R.begin(), info->R.end(), [](double v) { return std::isfinite(v); }) &&
          std::all_of(info->P.begin(), info->P.end(), [](double v) { return std::isfinite(v); });
      std::string what;
      if (!finite) {
        what = "is not finite (K or D)";
      } else if (!finite_rectification) {
        what = "is not finite (R or P)";
      } else if (info->K != was.K) {
        what = "changes (camera matrix K)";
      } else if (info->D != was.D || info->distortion_model != was.distortion_model) {
        what = "changes (distortion)";
      } else if (info->R != was.R) {
        // The first R was checked (a rotation); a later zero R would be accepted silently.
        what = "changes (rectification matrix R)";
      } else if (info->P != was.P) {
        what = "changes (projection matrix P)";
      } else if (stripSlash(info->header.frame_id) != stripSlash(was.header.frame_id)) {
        // The frame names the camera's /tf_static pose: a new one would move the camera.
        what =
            "changes (frame_id '" + was.header.frame_id + "' to '" + info->header.frame_id + "')";
      }
      if (!what.empty()) {
        const std::string stamp = formatStamp(info->header.stamp.toNSec());
        fail(message.getTopic() + ": the calibration of camera " + cameraName(ids[camera]) + " " +
             what + " at t=" + stamp + "; one calibration per camera is supported");
      }
      continue;
    }
    try {
      cameras[camera] = fromCameraInfo(*info, cameraName(ids[camera]));
    } catch (const InputError& error) {
      fail(std::string(error.what()) + " (" + message.getTopic() + " at " +
           formatStamp(info->header.stamp.toNSec()) + ")");
    }
    const std::string frame = stripSlash(info->header.frame_id);
    optical_frames[camera] = frame.empty() ? opticalFrame(cameraName(ids[camera])) : frame;
    first_infos[camera] = info;
    have[camera] = true;
    --missing;
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!have[i]) {
      fail("camera " + cameraName(ids[i]) + " has no camera_info (no messages on " +
           cameraInfoTopic(ids[i]) + ")");
    }
  }
  // The optical frame picks a camera's extrinsics from /tf_static: two cameras naming one frame
  // would get one pose (the second camera's silently the first's).
  const auto describe = [this](std::size_t i) {
    const std::string& frame_id = first_infos[i]->header.frame_id;
    return cameraInfoTopic(ids[i]) + " (frame_id '" + frame_id + "'" +
           (frame_id.empty() ? ", so '" + optical_frames[i] + "'" : std::string()) + ")";
  };
  for (std::size_t i = 1; i < ids.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (optical_frames[i] == optical_frames[j]) {
        fail(describe(j) + " and " + describe(i) + " name the same optical frame '" +
             optical_frames[i] + "': each camera needs a frame of its own in " + kTfStaticTopic);
      }
    }
  }
}

void BagReader::Impl::readExtrinsics() {
  std::map<std::string, ParentLink> links;  // child frame -> its parent
  rosbag::View tf_view(bag, rosbag::TopicQuery(kTfStaticTopic));
  for (const rosbag::ConnectionInfo* connection : tf_view.getConnections()) {
    if (connection->datatype != kTfType) {
      fail(std::string(kTfStaticTopic) + " has type " + connection->datatype + ", expected " +
           kTfType);
    }
  }
  const bool has_tf_static = tf_view.size() > 0;
  int message_number = 0;
  for (const rosbag::MessageInstance& message : tf_view) {
    ++message_number;
    const tf2_msgs::TFMessage::ConstPtr tf = read<tf2_msgs::TFMessage>(message);
    if (!tf) fail(std::string(kTfStaticTopic) + " does not hold tf2_msgs/TFMessage");
    for (const geometry_msgs::TransformStamped& transform : tf->transforms) {
      const std::string parent = stripSlash(transform.header.frame_id);
      const std::string child = stripSlash(transform.child_frame_id);
      ParentLink link{parent, Eigen::Isometry3d::Identity(), message_number, {}};
      try {
        link.parent_to_child = toIsometry(transform.transform);
      } catch (const InputError& error) {
        fail(std::string(kTfStaticTopic) + " " + parent + " -> " + child + ": " + error.what());
      }
      // tf2 keeps the last static transform of a frame without a word; a camera whose pose
      // changes within the bag has no one pose to track with. Noted here, refused below if the
      // frame is on a camera's chain.
      const auto known = links.find(child);
      if (known == links.end()) {
        links.emplace(child, std::move(link));
        continue;
      }
      ParentLink& first = known->second;
      const double metres =
          (link.parent_to_child.translation() - first.parent_to_child.translation()).norm();
      const double radians = Eigen::AngleAxisd(first.parent_to_child.linear().transpose() *
                                               link.parent_to_child.linear())
                                 .angle();
      if (first.conflict.empty() && (link.parent != first.parent || !(metres <= kSamePoseMetres) ||
                                     !(radians <= kSamePoseRadians))) {
        std::ostringstream conflict;
        conflict << "messages " << first.message << " and " << message_number << " of "
                 << kTfStaticTopic << " give '" << child << "' two poses (";
        if (link.parent != first.parent) {
          conflict << "under '" << first.parent << "' and under '" << link.parent << "'";
        } else {
          char amounts[96];
          std::snprintf(amounts, sizeof amounts, "%.1f mm and %.2f deg apart", 1000.0 * metres,
                        radians * 180.0 / M_PI);
          conflict << amounts;
        }
        conflict << "): a camera's extrinsics must not change within a bag";
        first.conflict = conflict.str();
      }
    }
  }

  std::vector<std::string> tops(ids.size());
  std::vector<Eigen::Isometry3d> top_to_camera(ids.size(), Eigen::Isometry3d::Identity());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::string& frame = optical_frames[i];
    const std::string missing = "missing extrinsics for camera " + cameraName(ids[i]) + ": ";
    if (!has_tf_static) fail(missing + "the bag has no " + kTfStaticTopic);
    if (frame != options.root_frame && links.find(frame) == links.end()) {
      fail(missing + "no transform to '" + frame + "' in " + kTfStaticTopic);
    }
    std::string current = frame;
    Eigen::Isometry3d current_to_camera = Eigen::Isometry3d::Identity();
    std::set<std::string> visited{current};
    while (current != options.root_frame) {
      const auto link = links.find(current);
      if (link == links.end()) break;
      if (!link->second.conflict.empty()) {
        fail("camera " + cameraName(ids[i]) + ": " + link->second.conflict);
      }
      current_to_camera = link->second.parent_to_child * current_to_camera;
      current = link->second.parent;
      if (!visited.insert(current).second) {
        fail(std::string(kTfStaticTopic) + " has a cycle through '" + current + "'");
      }
    }
    if (!options.root_frame.empty() && current != options.root_frame) {
      // The extrinsics are there: the chosen root frame is not one they can be expressed in.
      const bool in_tree = links.count(options.root_frame) > 0 ||
                           std::any_of(links.begin(), links.end(), [&](const auto& entry) {
                             return entry.second.parent == options.root_frame;
                           });
      if (!in_tree) {
        fail("root frame '" + options.root_frame + "' is not a frame of " + kTfStaticTopic +
             " (the cameras' tree's root is '" + current + "')");
      }
      fail("root frame '" + options.root_frame + "' is not above camera " + cameraName(ids[i]) +
           " ('" + frame + "') in " + kTfStaticTopic +
           ": it must be above every camera, e.g. the tree's root '" + current + "'");
    }
    tops[i] = current;
    top_to_camera[i] = current_to_camera;
  }
  for (std::size_t i = 1; i < ids.size(); ++i) {
    if (tops[i] != tops[0]) {
      fail("the cameras are in different tf trees: " + cameraName(ids[0]) + " under '" + tops[0] +
           "', " + cameraName(ids[i]) + " under '" + tops[i] + "'");
    }
  }
  root_frame = tops[0];
  // The rig file's limits (calibration.cpp) hold for a bag's extrinsics too: huge translations
  // overflow the inverse transform, cameras at one point see nothing in stereo. (kMaxCameras is
  // applied to the image topics, in discoverCameras.)
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const Eigen::Vector3d centre = top_to_camera[i].translation();
    if (!(centre.cwiseAbs().maxCoeff() <= kMaxRigExtentMetres)) {
      char text[160];
      std::snprintf(text, sizeof(text), "(%.6g, %.6g, %.6g)", centre.x(), centre.y(), centre.z());
      fail(std::string(kTfStaticTopic) + ": camera " + cameraName(ids[i]) + " is at " + text +
           " m in '" + root_frame + "'; translations must lie within +-" +
           shortNumber(kMaxRigExtentMetres) + " m");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if ((top_to_camera[j].translation() - centre).norm() < kMinCameraSeparation) {
        fail(std::string(kTfStaticTopic) + ": camera " + cameraName(ids[i]) +
             " is at the same point as camera " + cameraName(ids[j]) + " (closer than " +
             shortNumber(kMinCameraSeparation) + " m)");
      }
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    cameras[i].world_to_camera = top_to_camera[i].inverse();
  }
}

cv::Mat BagReader::Impl::decode(const sensor_msgs::Image& image, int camera,
                                const std::string& topic) const {
  const std::string where = topic + " at " + formatStamp(image.header.stamp.toNSec()) + ": ";
  // camera_info's frame_id chose the camera's frame in /tf_static; images of another frame would
  // be tracked with the extrinsics of the wrong one. (An empty frame_id names nothing.)
  const std::string& info_frame_id = first_infos[camera]->header.frame_id;
  if (!image.header.frame_id.empty() && !info_frame_id.empty() &&
      stripSlash(image.header.frame_id) != stripSlash(info_frame_id)) {
    fail(where + "frame_id '" + image.header.frame_id + "' differs from " +
         cameraInfoTopic(ids[camera]) + "'s frame_id '" + info_frame_id +
         "' (the frame whose /tf_static pose is the camera's)");
  }
  const Camera& calibration = cameras[camera];
  if (isSupportedEncoding(image.encoding) &&
      (static_cast<int>(image.width) != calibration.width ||
       static_cast<int>(image.height) != calibration.height)) {
    fail(where + "image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
         " but its camera_info says " + std::to_string(calibration.width) + "x" +
         std::to_string(calibration.height));
  }
  try {
    return toRgbMat(image);
  } catch (const InputError& error) {
    fail(where + error.what());
  }
}

void BagReader::Impl::checkFirstImages() {
  for (std::size_t i = 0; i < ids.size(); ++i) {
    rosbag::View first(bag, rosbag::TopicQuery(imageTopic(ids[i])));
    const auto message = first.begin();
    if (message == first.end()) continue;  // this camera delivers nothing; the others do
    const sensor_msgs::Image::ConstPtr image = read<sensor_msgs::Image>(*message);
    if (!image) fail(imageTopic(ids[i]) + " does not hold sensor_msgs/Image");
    decode(*image, static_cast<int>(i), imageTopic(ids[i]));
  }
}

void BagReader::Impl::noteDuplicateStamp(const std::function<std::string()>& image,
                                         std::int64_t stamp) {
  if (stats.duplicate_stamps++ == 0) {
    stats.first_duplicate_stamp = image() + " at " + formatStamp(stamp);
  }
}

void BagReader::Impl::noteNearStamps(const std::function<std::string()>& image, int camera,
                                     std::int64_t stamp) {
  // This image starts a set of its own; another camera's set close by that lacks it means the
  // cameras are not stamped together (closer than the tolerance it would have joined it).
  const std::int64_t period = frame_period[camera];
  const std::int64_t near = period == std::numeric_limits<std::int64_t>::max()
                                ? kNearStampNs
                                : std::max(kNearStampNs, period / 2);
  auto neighbour = pending.lower_bound(stamp - near);
  for (; neighbour != pending.end() && neighbour->first <= stamp + near; ++neighbour) {
    if (neighbour->first == stamp) continue;
    const std::vector<CameraImage>& images = neighbour->second.images;
    if (neighbour->second.has(camera) || images.empty()) continue;
    if (stats.near_stamp_mismatches++ == 0) {
      stats.first_near_stamp_mismatch = image() + " at " + formatStamp(stamp) + " vs " +
                                        cameraName(ids[images.front().camera]) + " at " +
                                        formatStamp(neighbour->first);
    }
    return;
  }
}

// The pending set an image of `camera` stamped `stamp` joins (camera_set_synchronizer.h's rule);
// end() for a new set.
std::map<std::int64_t, BagReader::Impl::PendingSet>::iterator BagReader::Impl::setFor(
    int camera, std::int64_t stamp) {
  return setWithinTolerance(pending, stamp, toleranceNs(options.stamp_tolerance),
                            [camera](const PendingSet& set) { return !set.has(camera); });
}

bool BagReader::Impl::frontIsFinal() const {
  const auto& [stamp, set] = *pending.begin();
  if (set.images.size() == ids.size()) return true;
  std::size_t next_image = 0;
  for (std::size_t camera = 0; camera < ids.size(); ++camera) {
    if (next_image < set.images.size() &&
        set.images[next_image].camera == static_cast<int>(camera)) {
      ++next_image;
      continue;
    }
    // Stamps of one camera only grow: once it has delivered an image newer than this set (beyond
    // the stamp tolerance), it skipped this set.
    if (last_stamp[camera] <= stamp + toleranceNs(options.stamp_tolerance)) return false;
  }
  return true;
}

bool BagReader::Impl::step(FrameSet* set) {
  while (true) {
    if (!pending.empty() &&
        (frontIsFinal() || static_cast<int>(pending.size()) > options.max_pending_sets ||
         it == end)) {
      auto front = pending.begin();
      set->stamp_ns = front->first;
      set->images = std::move(front->second.images);
      pending.erase(front);
      yielded_any = true;
      last_yielded = set->stamp_ns;
      ++stats.sets;
      if (set->images.size() < ids.size()) ++stats.incomplete_sets;
      return true;
    }
    if (it == end) return false;

    const rosbag::MessageInstance& message = *it;
    const std::string topic = message.getTopic();
    const sensor_msgs::Image::ConstPtr image = read<sensor_msgs::Image>(message);
    ++it;
    if (!image) fail(topic + " does not hold sensor_msgs/Image");
    ++stats.images_read;
    const int camera = topic_to_camera.at(topic);
    // The image as the stamp warnings name it: its topic and its frame number on that topic.
    // Made only for a warning's first image, not for every image read.
    const std::uint64_t frame = ++frames_read[camera];
    auto named = [&topic, frame] { return topic + " frame " + std::to_string(frame); };
    const std::int64_t stamp = static_cast<std::int64_t>(image->header.stamp.toNSec());
    if (stamp == 0) {
      fail(topic + ": image with a zero header stamp (sets are made by header stamps)");
    }
    if (stamp < last_stamp[camera] && stats.backward_stamps++ == 0) {
      stats.first_backward_stamp =
          named() + " at " + formatStamp(stamp) + " after " + formatStamp(last_stamp[camera]);
    }
    if (last_stamp[camera] != std::numeric_limits<std::int64_t>::min() &&
        stamp > last_stamp[camera] + kStampJumpNs && stats.forward_jumps++ == 0) {
      stats.first_forward_jump =
          named() + " at " + formatStamp(stamp) + " after " + formatStamp(last_stamp[camera]);
    }
    if (last_stamp[camera] != std::numeric_limits<std::int64_t>::min() &&
        stamp > last_stamp[camera]) {
      frame_period[camera] = std::min(frame_period[camera], stamp - last_stamp[camera]);
    }
    if (yielded_any && stamp <= last_yielded) {
      ++stats.dropped_images;  // too late: its set is gone
      if (stamp == last_stamp[camera]) noteDuplicateStamp(named, stamp);
      continue;
    }
    const auto found = setFor(camera, stamp);
    if (found == pending.end()) noteNearStamps(named, camera, stamp);
    PendingSet& target = found != pending.end() ? found->second : pending[stamp];
    if (found != pending.end() && found->first != stamp) {
      ++stats.tolerated_stamps;
      stats.largest_stamp_difference =
          std::max(stats.largest_stamp_difference,
                   1e-9 * static_cast<double>(std::llabs(stamp - found->first)));
    }
    auto position =
        std::lower_bound(target.images.begin(), target.images.end(), camera,
                         [](const CameraImage& image, int index) { return image.camera < index; });
    if (position != target.images.end() && position->camera == camera) {
      ++stats.dropped_images;  // a second image of this camera with the same stamp
      noteDuplicateStamp(named, stamp);
      continue;
    }
    CameraImage decoded;
    decoded.camera = camera;
    decoded.rgb = decode(*image, camera, topic);
    target.images.insert(position, std::move(decoded));
    last_stamp[camera] = std::max(last_stamp[camera], stamp);
  }
}

namespace {

std::string toleranceText(const BagReaderStatistics& stats, const std::string& option) {
  return "the stamp tolerance of " + shortNumber(1e3 * stats.stamp_tolerance) + " ms" +
         (option.empty() ? "" : " (" + option + ")");
}

std::string nearStampText(const BagReaderStatistics& stats, const std::string& option) {
  return std::to_string(stats.near_stamp_mismatches) + " images more than " +
         toleranceText(stats, option) + " but at most half their camera's frame period (" +
         shortNumber(1e-6 * kNearStampNs) + " ms or more) from another camera's set";
}

std::string plural(std::uint64_t count, const std::string& word) {
  return std::to_string(count) + " " + word + (count == 1 ? "" : "s");
}

}  // namespace

std::vector<std::string> stampWarnings(const BagReaderStatistics& stats,
                                       const std::string& tolerance_option) {
  std::vector<std::string> lines;
  if (stats.backward_stamps > 0) {
    lines.push_back(std::to_string(stats.backward_stamps) +
                    " images with stamps going backwards (first: " + stats.first_backward_stamp +
                    "); images whose set was already read are dropped");
  }
  if (stats.duplicate_stamps > 0) {
    lines.push_back(std::to_string(stats.duplicate_stamps) +
                    " images with the stamp of an earlier image of their camera (first: " +
                    stats.first_duplicate_stamp + "); only the first image of a stamp is used");
  }
  if (stats.forward_jumps > 0) {
    lines.push_back(std::to_string(stats.forward_jumps) + " images with stamps more than " +
                    shortNumber(kStampJumpSeconds) +
                    " s after their camera's previous image (first: " + stats.first_forward_jump +
                    "); a clock set forward or a paused recording, read as the next frame");
  }
  if (stats.near_stamp_mismatches > 0) {
    lines.push_back(nearStampText(stats, tolerance_option) +
                    " (first: " + stats.first_near_stamp_mismatch +
                    "): the cameras are not stamped together, so these are never seen together");
  }
  return lines;
}

std::string stampFailure(const BagReaderStatistics& stats, long sets,
                         const std::string& tolerance_option) {
  const std::uint64_t kept = static_cast<std::uint64_t>(std::max(0L, sets));
  if (stats.near_stamp_mismatches > 0) {
    return "the cameras' stamps do not match (" + nearStampText(stats, tolerance_option) +
           ", first: " + stats.first_near_stamp_mismatch +
           "); a set is made of the stamps within " + toleranceText(stats, tolerance_option) +
           " of each other";
  }
  if (stats.backward_stamps > kept) {
    return std::to_string(stats.backward_stamps) +
           " images were dropped because their stamps go backwards (first: " +
           stats.first_backward_stamp + "), against " + plural(kept, "set") +
           " kept; the bag's images must come in the order of their stamps";
  }
  if (stats.duplicate_stamps > kept) {
    return std::to_string(stats.duplicate_stamps) +
           " images were dropped because they repeat a stamp their camera already had (first: " +
           stats.first_duplicate_stamp + "), against " + plural(kept, "set") +
           " kept; each image of a camera needs a stamp of its own";
  }
  return "";
}

bool camerasOutOfStep(const BagReaderStatistics& stats, long sets) {
  return stats.near_stamp_mismatches > 0 &&
         10 * stats.near_stamp_mismatches >= static_cast<std::uint64_t>(std::max(1L, sets));
}

BagReader::BagReader(const std::string& path, const BagReaderOptions& options)
    : impl_(std::make_unique<Impl>(path, options, nullptr)) {
  impl_->translateErrors([this] { impl_->open(); });
}

BagReader::BagReader(const std::string& path, rosbag::Bag& reused_bag,
                     const BagReaderOptions& options)
    : impl_(std::make_unique<Impl>(path, options, &reused_bag)) {
  impl_->translateErrors([this] { impl_->open(); });
}

BagReader::~BagReader() = default;
BagReader::BagReader(BagReader&&) noexcept = default;
BagReader& BagReader::operator=(BagReader&&) noexcept = default;

const std::string& BagReader::path() const { return impl_->path; }
const std::string& BagReader::rootFrame() const { return impl_->root_frame; }
const std::vector<Camera>& BagReader::cameras() const { return impl_->cameras; }
bool isBagCameraName(const std::string& name) {
  for (int id = 0; id < kMaxCameras; ++id) {
    if (name == cameraName(id)) return true;
  }
  return false;
}

const std::vector<int>& BagReader::cameraIds() const { return impl_->ids; }
const BagReaderStatistics& BagReader::statistics() const { return impl_->stats; }

double BagReader::progress() const {
  const BagReaderStatistics& stats = impl_->stats;
  if (stats.image_messages == 0) return 1.0;
  return std::min(1.0, static_cast<double>(stats.images_read) / stats.image_messages);
}

bool BagReader::next(FrameSet* set) {
  const auto start = std::chrono::steady_clock::now();
  bool more = false;
  impl_->translateErrors([&] { more = impl_->step(set); });
  impl_->stats.decode_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return more;
}

}  // namespace sag_hand_tracker
