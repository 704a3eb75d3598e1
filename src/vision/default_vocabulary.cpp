// The default vocabulary, compiled in from share/rost/default.rostvoc (see
// embed.cmake and share/rost/README.md).

#include <mutex>

#include "rost/vision/words.hpp"

namespace rost::vision {

namespace detail {
extern const unsigned char kDefaultVocabulary[];
extern const std::size_t kDefaultVocabularySize;
} // namespace detail

std::shared_ptr<const Vocabulary> defaultVocabulary(Status& status) {
    static std::once_flag once;
    static std::shared_ptr<const Vocabulary> vocabulary;
    static Status loaded;
    std::call_once(once, [] {
        if (detail::kDefaultVocabularySize == 0) {
            loaded = Status::error("this build has no default vocabulary (share/rost/default.rostvoc was missing "
                                   "at build time); give one with --vocabulary FILE");
            return;
        }
        auto v = std::make_shared<Vocabulary>();
        loaded = Vocabulary::parse({detail::kDefaultVocabulary, detail::kDefaultVocabularySize},
                                   "(built-in default)", *v);
        if (loaded.ok()) vocabulary = std::move(v);
    });
    status = loaded;
    return vocabulary;
}

} // namespace rost::vision
