import pytest

from webapp.engine.bus import MemoryBus, SubscriberTooSlow


async def test_publish_reaches_every_subscriber_of_that_wall_only() -> None:
    bus = MemoryBus(queue_size=8)
    async with (
        bus.subscribe("a") as first,
        bus.subscribe("a") as second,
        bus.subscribe("b") as other,
    ):
        await bus.publish("a", "hello")
        assert await first.next() == "hello"
        assert await second.next() == "hello"
        assert other.drain() == []


async def test_messages_arrive_in_publication_order() -> None:
    bus = MemoryBus(queue_size=8)
    async with bus.subscribe("a") as subscription:
        for index in range(5):
            await bus.publish("a", str(index))
        assert [await subscription.next() for _ in range(5)] == ["0", "1", "2", "3", "4"]


async def test_slow_subscriber_is_dropped_without_blocking_others() -> None:
    bus = MemoryBus(queue_size=2)
    async with bus.subscribe("a") as slow, bus.subscribe("a") as fast:
        for index in range(4):
            await bus.publish("a", str(index))
            assert await fast.next() == str(index)
        assert slow.overflowed and not fast.overflowed
        assert await slow.next() == "0"
        assert await slow.next() == "1"
        with pytest.raises(SubscriberTooSlow):
            await slow.next()


async def test_leaving_unsubscribes() -> None:
    bus = MemoryBus(queue_size=2)
    async with bus.subscribe("a") as subscription:
        pass
    await bus.publish("a", "after")
    assert subscription.drain() == []
