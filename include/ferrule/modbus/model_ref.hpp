// model_ref: one data model served by several server sessions (the connections of a TCP
// server, or an RTU port and a TCP port of a gateway). server<M> keeps its model by value;
// server<model_ref<M>> keeps a reference to one that lives elsewhere.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"

namespace ferrule::modbus {

template <data_model M>
class model_ref {
public:
    explicit model_ref(M& model) noexcept : m_(&model) {}

    std::uint8_t read_bits(function fc, std::uint16_t address, std::uint16_t quantity,
                           std::span<std::uint8_t> out) {
        return m_->read_bits(fc, address, quantity, out);
    }
    std::uint8_t read_registers(function fc, std::uint16_t address, std::uint16_t quantity,
                                std::span<std::uint8_t> out) {
        return m_->read_registers(fc, address, quantity, out);
    }
    std::uint8_t write_coils(std::uint16_t address, std::uint16_t quantity,
                             std::span<const std::uint8_t> packed) {
        return m_->write_coils(address, quantity, packed);
    }
    std::uint8_t write_registers(std::uint16_t address, std::uint16_t quantity,
                                 std::span<const std::uint8_t> data) {
        return m_->write_registers(address, quantity, data);
    }
    std::string_view device_id(std::uint8_t object_id) { return m_->device_id(object_id); }

    M& get() const noexcept { return *m_; }

private:
    M* m_;
};

} // namespace ferrule::modbus
